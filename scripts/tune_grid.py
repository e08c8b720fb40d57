#!/usr/bin/env python
"""Tune every family at a grid of paper A's models and write the tunings the package ships
(``isl_core/scenario/data/tunings.json``, :ref:`shipped-tunings`).

    python scripts/tune_grid.py                      # the shipped grid, on two threads
    python scripts/tune_grid.py --alpha 0.5 1 --m 3  # a part of it, written elsewhere with --out

Each point is :func:`isl_core.tune` at (α, m, w = 3) with the rule's defaults (32 seeds, horizon 30/r_min, the table's
presets and grids), cached on disk as usual (an interrupted run resumes from the cache). The file keeps per point each
family's knob and minimax figure, the rule (:func:`isl_core.scenario.shipped.rule`) and the probe — a small tuning
whose cells' digest a test recomputes bit for bit. The file is rewritten after every point, points in the order
given (m first, then α), so a run stopped early leaves a usable file of the points done; a point already in the file
is kept when the file's rule is today's and its probe recomputes bit for bit.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from isl_core import Execution
from isl_core.scenario.shipped import COMMAND, SHIPPED, W_GRID, entry_from, probe_record, probe_tuning, rule
from isl_core.scenario.tuning import tune

#: (m, α) in the order computed, the most useful first: the default page's model, the scenario table's (α = 1), every
#: other m at one α, then more α per m, the dearest last (the steps a seed grow with α at m ≥ 2; α = 25 and 100 only
#: at m = 1, where they are cheap: at m ≥ 2 they need 1.4–12 million steps a seed over the presets, hours a point)
POINTS = (
    (3, 0.5),
    (3, 1.0),
    (4, 0.5),
    (5, 0.5),
    (1, 5.0),
    (6, 1.0),
    (2, 0.04),
    (3, 0.2),
    (3, 0.04),
    (1, 25.0),
    (1, 100.0),
    (1, 0.5),
    *((m, a) for a in (0.2, 1.0, 0.04) for m in (4, 5, 6) if (m, a) != (6, 1.0)),
    (2, 0.2),
    (6, 0.5),
    (1, 1.0),
    (2, 0.5),
    (1, 0.2),
    (1, 0.04),
    *((m, 5.0) for m in (3, 4, 5, 6)),
    (2, 1.0),
)


def _write(path: Path, record: dict) -> None:
    """``record`` as JSON at ``path``, atomically (a reader sees the old file or the whole new one)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile("w", dir=path.parent, suffix=".json", delete=False, encoding="utf-8") as tmp:
        json.dump(record, tmp, indent=1, ensure_ascii=False)
        tmp.write("\n")
    os.chmod(tmp.name, 0o644)  # readable by the server's user, as any file of the package (a temporary file is 0600)
    os.replace(tmp.name, path)


def _kept(path: Path, record: dict) -> dict[tuple[float, int], dict]:
    """The points of the file at ``path`` if it was made under the same rule and its probe recomputes bit for bit
    (then the core computes what it computed): they need no new run."""
    try:
        old = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return {}
    if old.get("rule") != record["rule"] or old.get("probe") != record["probe"]:
        return {}
    return {(e["alpha"], e["m"]): e for e in old["entries"]}


def markdown(record: dict) -> str:
    """The file's grid as the table of the scenarios page: per point each family's knob and the computing time."""
    from isl_core.scenario.table import knob_text

    head = "| m | α (w = 3) | ISL ν/β | model-aware ν/β | adaptive | VB | robust | IMM | s |\n" + "|---" * 9 + "|\n"
    rows = []
    for e in sorted(record["entries"], key=lambda e: (e["m"], e["alpha"])):
        k = e["knobs"]
        cells = [f"{2.0 ** k[f]['ell']:.3g}" for f in ("isl", "isl_model")]
        cells += [knob_text(k[f]) for f in ("kbf_adaptive", "vb", "kbf_robust")]
        cells.append(f"p = {k['imm']['switch']:g}, J = {k['imm']['modes']}")
        rows.append(f"| {e['m']} | {e['alpha']:g} | " + " | ".join(cells) + f" | {e['seconds']:.0f} |")
    return head + "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--alpha", type=float, nargs="+", help="α of the grid (w = 3; default: every point's)")
    parser.add_argument("--m", type=int, nargs="+", help="m of the grid (with --alpha: every α at every m)")
    parser.add_argument("--workers", type=int, default=2, help="threads per tuning (default 2)")
    parser.add_argument("--out", type=Path, default=SHIPPED, help=f"where to write (default {SHIPPED})")
    parser.add_argument("--markdown", action="store_true", help="print the file's grid as a Markdown table, and stop")
    args = parser.parse_args(argv)
    if args.markdown:
        print(markdown(json.loads(args.out.read_text(encoding="utf-8"))))
        return 0
    start = time.perf_counter()
    probe = probe_tuning(args.workers)
    record = {
        "about": "every family's minimax knob at a grid of paper A's models (w = 3); see the scenarios page",
        "command": COMMAND,
        "rule": rule(),
        "probe": probe_record(probe),
        "entries": [],
        "seconds": round(probe.seconds, 1),
    }
    kept = _kept(args.out, record)
    print(f"probe: {probe.seconds:.0f} s; {len(kept)} points kept from {args.out}", flush=True)
    points = POINTS if args.alpha is None else [(m, a) for m in args.m or (3,) for a in args.alpha]
    for m, alpha in points:
        if (alpha, m) in kept:
            record["entries"].append(kept[alpha, m])
            continue
        res = tune(alpha, m=m, w=W_GRID, execution=Execution(workers=args.workers))
        assert res is not None  # computed when not cached
        record["entries"].append(entry_from(res))
        record["seconds"] = round(probe.seconds + sum(e["seconds"] for e in record["entries"]), 1)
        _write(args.out, record)
        print(f"α = {alpha:g}, m = {m}: {res.seconds:.0f} s ({res.origin})", flush=True)
    print(f"{len(record['entries'])} points, {time.perf_counter() - start:.0f} s: {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
