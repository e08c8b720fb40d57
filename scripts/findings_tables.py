#!/usr/bin/env python3
"""Lay out the findings page's tables (docs/findings.md) from the commands' JSON, as Markdown.

    isl scenario --json > table.json
    isl worstcase --json > worstcase.json
    .venv/bin/python scripts/findings_tables.py table.json [worstcase.json]
    .venv/bin/python scripts/findings_tables.py --rates table-10.json table-30.json table-100.json …
    .venv/bin/python scripts/findings_tables.py --converged table-100.json table-100-refined.json

``--rates`` lays the tables at several reading rates (``isl scenario --rate R --json``) side by side: each row's
minimax knob and worst held-out cell per rate, the winner of each cell per rate, the knobs at their grid's end.
``--converged`` compares a table with the same table at h/2 (``--refine 1``): per row and cell, how far the cell
moved in units of its interval's half-width; ``--converged-curves`` the same for every variant of every family at its
own knob, from two tunings (``isl scenario --tune --json`` and ``--refine 1 --tune --json``), and each family's minimax
on both. ``--curve FAMILY tune.json`` prints one family's minimax objective (its largest ratio over every cell) per
knob, on the tuning's seeds.

Prints, in the page's order: the fair table (σ changes; tails, sensor, constant σ), each tuned row out of sample, who
wins each cell, the rows beyond every assumed σ range, and — with the worst-case JSON — the worst case over σ per α and
the minimax ν/β against table (A.31)'s. Every figure is the JSON's, rounded as the page shows it; nothing is computed
here but ratios of two printed figures (held-out over tuning-seed).
"""

from __future__ import annotations

import json
import math
import sys

NAMES = {
    "clairvoyant": "clairvoyant (reference)",
    "kbf": "Kalman–Bucy for σ(0) (reference)",
    "isl": "ISL (paper A)",
    "isl_model": "ISL model-aware",
    "kbf_adaptive": "adaptive (Mehra)",
    "vb": "variational Bayes",
    "kbf_robust": "robust (Huber)",
    "imm": "IMM",
    "isl_a31": "ISL at (A.31)'s ν",
}
CELLS = {
    "sigma_drop:after_1": "drop, 1st 1/r",
    "sigma_drop:after_2": "drop, 1st 2/r",
    "sigma_drop:settled": "drop, settled",
    "sigma_rise:after_1": "rise, 1st 1/r",
    "sigma_rise:after_2": "rise, 1st 2/r",
    "sigma_rise:settled": "rise, settled",
    "student3:settled": "Student-t, d = 3",
    "outliers:settled": "1 % outliers × 30",
    "sensor:settled": "sensor every 0.1/r_min",
    "constant:settled": "constant σ",
    "sigma_2000:settled": "σ = 2000, settled",
    "sigma_drop_far:after_1": "200 → 0.5, 1st 1/r",
    "sigma_drop_far:after_2": "200 → 0.5, 1st 2/r",
    "sigma_drop_far:settled": "200 → 0.5, settled",
}
KNOBS = {"ell": "ℓ = {:g}", "memory": "W = {:g}", "c": "c = {:g}", "switch": "p = {:g}", "modes": "J = {:g}"}
WC_LABELS = {
    "kbf": "KBF that knows σ",
    "isl": "ISL, minimax ν",
    "isl_a31": "ISL, (A.31)'s ν",
    "isl_model": "ISL model-aware, minimax ν",
    "kbf_mismatched": "KBF for σ = 20 (fixed gain)",
    "kbf_minimax": "KBF for σ = 200 (fixed gain)",
    "kbf_adaptive": "adaptive KBF, W = 1000",
}


def fmt(x) -> str:
    if x is None or not math.isfinite(x):
        return "—" if x is None or math.isnan(x) else "∞"
    return f"{x:.3f}" if x < 10 else f"{x:.2f}" if x < 100 else f"{x:.4g}"


def cell(c: dict) -> str:
    text = f"{fmt(c['ratio'])} [{fmt(c['low'])}, {fmt(c['high'])}] X{c['coordinate']}"
    return text + (f", {c['seeds_diverged']} diverged" if c.get("seeds_diverged") else "")


def knob(row: dict) -> str:
    if row["role"] == "reference":
        return "—"
    if row["name"] == "isl_a31":  # its label: "ISL at table (A.31)'s ν/β = 0.2 (ν = …)"
        return row["label"].split("'s ", 1)[1].split(" (")[0]
    return ", ".join(KNOBS[k].format(v) for k, v in row["tuning"].items())


def header(first: list[str], keys: list[str]) -> list[str]:
    return ["| " + " | ".join(first + [CELLS.get(k, k) for k in keys]) + " |", "|" + "---|" * (len(first) + len(keys))]


def table(doc: dict) -> list[str]:
    rows = [r for r in doc["rows"] if r["role"] != "oracle"]
    keys = [c["cell"] for c in doc["meta"]["cells"]]
    changes = [k for k in keys if k.startswith(("sigma_drop:", "sigma_rise:"))]
    out = []
    for group in (changes, [k for k in keys if k not in changes]):
        out += header(["row", "knob"], group)
        out += [
            f"| {NAMES[r['name']]} | {knob(r)} | " + " | ".join(cell(r["cells"][k]) for k in group) + " |" for r in rows
        ]
        out.append("")
    return out


def out_of_sample(doc: dict) -> list[str]:
    seeds, report = doc["meta"]["tuning_seeds"], doc["meta"]["report_seeds"]
    out = [
        f"| row | tuning seeds {seeds[0]}–{seeds[1]} (its worst cell, interval) | report seeds {report[0]}–{report[1]} "
        "| held-out / tuning | flagged | worst seed (cell) | most seeds > 2× in one cell |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in doc["rows"]:
        if r["role"] not in ("tuned", "paper"):
            continue
        cells, t = r["cells"], r["tuning_seed_figure"]
        worst = max(cells, key=lambda k: cells[k]["worst_seed"])
        out.append(
            f"| {NAMES[r['name']]} | {fmt(t['ratio'])} [{fmt(t['low'])}, {fmt(t['high'])}] | "
            f"{fmt(r['held_out_figure'])} | {r['held_out_over_tuning']:.2f}× | "
            f"{'**flagged**' if r['flagged'] else 'no'} | {fmt(cells[worst]['worst_seed'])} (seed "
            f"{cells[worst]['worst_seed_id']}, {worst}) | {r['most_seeds_above_2x_in_a_cell']} |"
        )
    return [*out, ""]


def winners(doc: dict) -> list[str]:
    out = ["| cell | winner | runner-up | margin (lower bound) |", "|---|---|---|---|"]
    for w in doc["winners"]:
        a, b = NAMES[w["winner"]], NAMES[w["runner_up"]]
        m, lo = w["margin"], w["margin_low95"]
        out.append(
            f"| {w['cell']} | tie: {a}, {b} | | {m:.4f} ({lo:.4f}) |"
            if w["tie"]
            else f"| {w['cell']} | {a} | {b} | {m:.4f}× ({lo:.4f}) |"
        )
    return [*out, ""]


def beyond(doc: dict) -> list[str]:
    b = doc.get("beyond") or {}
    if not b:
        return []
    keys = list(next(iter(b["rows"].values()))["cells"])
    out = header(["row", "assumes"], keys)
    out += [
        f"| {NAMES[n]} | {r['assumes']} | " + " | ".join(cell(r["cells"][k]) for k in keys) + " |"
        for n, r in b["rows"].items()
    ]
    return [*out, ""]


def worst_case(doc: dict) -> list[str]:
    meta, by = doc["meta"], {(r["alpha"], r["filter"]): r for r in doc["rows"]}
    alphas = meta["alphas"]
    out = ["| filter | " + " | ".join(f"α = {a:g}" for a in alphas) + " |", "|---|" + "---|" * len(alphas)]
    for name in meta["filters"]:
        vals = [by[(a, name)] for a in alphas]
        out.append(
            f"| {WC_LABELS.get(name, name)} | "
            + " | ".join(
                "—" if v["worst"] is None else f"{fmt(v['worst'])} [{fmt(v['worst_low'])}, {fmt(v['worst_high'])}]"
                for v in vals
            )
            + " |"
        )
    best = zip(meta["best_fixed_kbf_worst"], meta["best_fixed_kbf_sigma"], strict=True)
    out.append(
        "| best fixed-gain KBF, theory (its design σ) | " + " | ".join(f"{w:.3f} (σ = {s:.3g})" for w, s in best) + " |"
    )
    out += ["", "| | " + " | ".join(f"α = {a:g}" for a in alphas) + " |", "|---|" + "---|" * len(alphas)]
    for name, label in (
        ("isl", "ν*/β (minimax, ISL)"),
        ("isl_a31", "ν/β of (A.31)"),
        ("isl_model", "ν*/β (model-aware)"),
    ):
        ratios = [by[(a, name)]["nu"] / by[(a, name)]["beta"] if by[(a, name)]["nu"] else None for a in alphas]
        out.append(f"| {label} | " + " | ".join("—" if x is None else f"{x:.3g}" for x in ratios) + " |")
    return [*out, ""]


def _load(path: str) -> dict:
    with open(path) as fh:
        return json.load(fh)


def rates(docs: list[dict]) -> list[str]:
    """Each row's knob and worst held-out cell, and each cell's winner, per reading rate."""
    heads = [f"R = {d['meta']['rate_readings_per_r_min']:g}" for d in docs]
    out = ["| row | " + " | ".join(heads) + " |", "|---|" + "---|" * len(docs)]
    by = [{r["name"]: r for r in d["rows"]} for d in docs]
    for r in docs[0]["rows"]:
        if r["role"] not in ("tuned", "paper", "reference"):
            continue
        parts = []
        for rows in by:
            row = rows[r["name"]]
            worst = max(row["cells"], key=lambda k: _key(row["cells"][k]["ratio"]))
            flag = ", **flagged**" if row.get("flagged") else ""
            parts.append(f"{knob(row)}: {fmt(row['cells'][worst]['ratio'])} ({CELLS.get(worst, worst)}{flag})")
        out.append(f"| {NAMES[r['name']]} | " + " | ".join(parts) + " |")
    out += ["", "| cell | " + " | ".join(heads) + " |", "|---|" + "---|" * len(docs)]
    winners = [{w["cell"]: w for w in d["winners"]} for d in docs]
    for w in docs[0]["winners"]:
        parts = []
        for ws in winners:
            x = ws[w["cell"]]
            a = NAMES[x["winner"]]
            parts.append(f"tie: {a}, {NAMES[x['runner_up']]}" if x["tie"] else f"{a} ({x['margin']:.2f}×)")
        out.append(f"| {CELLS.get(w['cell'], w['cell'])} | " + " | ".join(parts) + " |")
    out += ["", "| grid | " + " | ".join(heads) + " |", "|---|" + "---|" * len(docs)]
    out.append(
        "| minimax at a grid's end | "
        + " | ".join(
            "; ".join(f"{f}: {', '.join(f'{k} {v}' for k, v in e.items())}" for f, e in edges.items()) or "none"
            for edges in (d["meta"].get("minimax_on_grid_edge", {}) for d in docs)
        )
        + " |"
    )
    steps = [d["meta"]["steps_per_reading"] for d in docs]
    for preset in docs[0]["meta"]["steps_per_reading"]:
        out.append(
            f"| {preset}: steps a reading (h) | "
            + " | ".join(f"{s[preset]} ({d['meta']['h'][preset]:.3g})" for s, d in zip(steps, docs, strict=True))
            + " |"
        )
    return [*out, ""]


def _key(x) -> float:
    return math.inf if x is None else x


def converged(coarse: dict, fine: dict) -> list[str]:
    """How far each row's cells moved from h to h/2, in units of the coarse cell's interval half-width."""
    rate = coarse["meta"]["rate_readings_per_r_min"]
    qs = (coarse["meta"]["steps_per_reading"], fine["meta"]["steps_per_reading"])
    out = [
        f"R = {rate:g}: steps a reading {qs[0]} → {qs[1]}",
        "",
        "| row | largest move / half-width (cell) | cells moved more than the half-width |",
        "|---|---|---|",
    ]
    rows = {r["name"]: r for r in fine["rows"]}
    worst_all = 0.0
    for r in coarse["rows"]:
        if r["role"] == "oracle":
            continue
        moves = {}
        for k, c in r["cells"].items():
            f = rows[r["name"]]["cells"][k]
            half = (c["high"] - c["low"]) / 2.0 if c["high"] is not None and c["low"] is not None else None
            if half and f["ratio"] is not None and c["ratio"] is not None:
                moves[k] = abs(f["ratio"] - c["ratio"]) / half
        k = max(moves, key=moves.get)
        worst_all = max(worst_all, moves[k])
        over = [CELLS.get(c, c) for c, v in moves.items() if v > 1.0]
        out.append(f"| {NAMES[r['name']]} | {moves[k]:.3f} ({CELLS.get(k, k)}) | {', '.join(over) or 'none'} |")
    out += ["", f"largest over every row and cell: {worst_all:.3f} of a half-width", ""]
    return out


def _objective(doc: dict) -> dict[str, tuple[dict, float, bool]]:
    """Per variant: its knob, its largest ratio over the cells (the minimax objective) and whether it is the minimax."""
    out: dict[str, tuple[dict, float, bool]] = {}
    for c in doc["curves"]:
        knob = {k: c[k] for k in KNOBS if k in c}
        prev = out.get(c["variant"], (knob, -math.inf, False))
        out[c["variant"]] = (knob, max(prev[1], _key(c["ratio"])), c["minimax"])
    return out


def curve(family: str, doc: dict) -> list[str]:
    """One family's minimax objective per knob (* the minimax)."""
    out = [f"| {family}: knob | largest ratio over the cells |", "|---|---|"]
    for name, (knob, worst, best) in _objective(doc).items():
        if name.startswith(family + "@"):
            text = ", ".join(KNOBS[k].format(v) for k, v in knob.items())
            out.append(f"| {'**' if best else ''}{text}{'** (minimax)' if best else ''} | {fmt(worst)} |")
    return [*out, ""]


def converged_curves(coarse: dict, fine: dict) -> list[str]:
    """Every variant at its own knob, h against h/2, in units of the coarse cell's half-width; each family's minimax."""
    moves: dict[str, list[float]] = {}
    fine_cells = {(c["variant"], c["cell"]): c for c in fine["curves"]}
    for c in coarse["curves"]:
        f = fine_cells[(c["variant"], c["cell"])]
        if None in (c["ratio"], c["low"], c["high"], f["ratio"]) or c["high"] <= c["low"]:
            continue
        moves.setdefault(c["family"], []).append(abs(f["ratio"] - c["ratio"]) / ((c["high"] - c["low"]) / 2.0))
    out = [
        "| family | variants × cells | largest move / half-width | moved > half-width | minimax at h → h/2 |",
        "|---|---|---|---|---|",
    ]
    best = [{n: (k, w) for n, (k, w, b) in _objective(d).items() if b} for d in (coarse, fine)]
    for family, m in moves.items():
        ends = []
        for b in best:
            (knob, worst) = next(v for n, v in b.items() if n.startswith(family + "@"))
            ends.append(f"{', '.join(KNOBS[k].format(v) for k, v in knob.items())} ({fmt(worst)})")
        out.append(f"| {family} | {len(m)} | {max(m):.3f} | {sum(x > 1.0 for x in m)} | {ends[0]} → {ends[1]} |")
    return [*out, ""]


def main(argv: list[str]) -> int:
    if argv[:1] == ["--converged-curves"] and len(argv) == 3:
        print("\n".join(converged_curves(_load(argv[1]), _load(argv[2]))))
        return 0
    if argv[:1] == ["--curve"] and len(argv) == 3:
        print("\n".join(curve(argv[1], _load(argv[2]))))
        return 0
    if argv[:1] == ["--rates"] and len(argv) >= 2:
        print("\n".join(rates([_load(p) for p in argv[1:]])))
        return 0
    if argv[:1] == ["--converged"] and len(argv) == 3:
        print("\n".join(converged(_load(argv[1]), _load(argv[2]))))
        return 0
    if len(argv) not in (1, 2):
        print(__doc__, file=sys.stderr)
        return 2
    with open(argv[0]) as fh:
        doc = json.load(fh)
    lines = table(doc) + out_of_sample(doc) + winners(doc) + beyond(doc)
    if len(argv) == 2:
        with open(argv[1]) as fh:
            lines += worst_case(json.load(fh))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
