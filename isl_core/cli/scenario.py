"""``isl scenario``: the fair table (default), the tuning curves (``--tune``) and the who-wins maps (``--map``).

Every figure comes from :mod:`isl_core.scenario.tuning` (one tuning rule for every family, cached),
:mod:`isl_core.scenario.table` and :mod:`isl_core.scenario.map`; this module only prints them or writes them
as CSV/JSON.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from .commands import UsageError, flat, nan_to_none, progress_bar, write_csv

if TYPE_CHECKING:
    from ..requests import Execution
    from ..scenario.table import ScenarioTable
    from ..scenario.tuning import Tuning

__all__ = ["cmd_scenario"]


def _ratio(x: float) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{x:.3f}" if x < 10 else f"{x:.2f}" if x < 100 else f"{x:.4g}"


def _execution(args: argparse.Namespace, what: str, *, quiet: bool) -> Execution:
    """How the command runs a job: ``--workers`` threads, ``--no-cache``, a progress bar for ``what``."""
    from ..requests import Execution

    return Execution(args.workers, progress=progress_bar(what, not quiet), cache=not args.no_cache)


def _tuning(args: argparse.Namespace, *, quiet: bool) -> Tuning:
    from ..requests import Sampling
    from ..scenario.table import PRESETS
    from ..scenario.tuning import tune

    names = flat(args.scenarios)
    unknown = [n for n in names if n not in PRESETS]
    if unknown:
        raise UsageError(f"isl scenario: unknown scenario {unknown[0]!r}; choose from {', '.join(PRESETS)}")
    return cast(  # computed, or read from the cache: never None
        "Tuning",
        tune(
            args.alpha,
            m=args.m,
            w=args.w,
            presets={n: PRESETS[n] for n in names},
            sampling=Sampling.first(32 if args.n_seeds is None else args.n_seeds, horizon=args.horizon, burn=args.burn),
            execution=_execution(args, "tuning", quiet=quiet),
            rate=args.rate,
            refine=args.refine,
        ),
    )


def cmd_scenario(args: argparse.Namespace) -> int:
    """The table, the tuning curves or a map (module docstring)."""
    if args.map is not None:
        from .scenario_map import scenario_map

        return scenario_map(args)
    res = _tuning(args, quiet=args.quiet or args.json)
    return _tune_out(args, res) if args.tune else _table_out(args, res)


def _meta(res: Tuning) -> dict[str, Any]:
    from .. import shipped_json
    from ..scenario.tuning import FAMILIES

    return {
        "alpha": res.alpha,
        "m": res.m,
        "w": res.w,
        "tuning_seeds": [res.seeds[0], res.seeds[-1]],
        "horizon_over_r_min": res.horizon,
        "burn_over_r_min": res.burn,
        "origin": res.origin,
        "statistic": "per period and coordinate i: sqrt of (sum over seeds and steps of e_i^2) / "
        "(seeds x sum over steps of the clairvoyant P_ii); a cell's figure is its worst coordinate's; interval: "
        "Student's over the seeds' contributions, under the square root",
        "scenarios": dict(zip(res.presets, res.preset_labels, strict=True)),
        "one_reading_over_r_min": dict(zip(res.presets, res.reading_time, strict=True)),
        "steps": dict(zip(res.presets, res.steps, strict=True)),
        "rate_readings_per_r_min": res.rate,
        "refine": res.refine,
        "h": dict(zip(res.presets, res.h, strict=True)),
        "steps_per_reading": dict(zip(res.presets, res.substeps, strict=True)),
        "minimax_on_grid_edge": {f: res.on_edge(f) for f in FAMILIES if res.on_edge(f)},
        "shipped_tuning": shipped_json(res.alpha, res.m, res.w),  # what the dashboard uses without a computed tuning
    }


def _cell_key(res: Tuning, c: int) -> str:
    p, period = res.cells[c]
    return f"{res.presets[p]}:{period.name}"


def _costs(res: Tuning, tab: ScenarioTable, args: argparse.Namespace) -> tuple[dict[str, float], dict[str, Any]]:
    """ns per step of each row's filter (the tuned ones, the σ(0) Kalman–Bucy, the paper's ISL), measured."""
    if args.no_cost:
        return {}, {}
    import dataclasses

    from ..filters.isl import isl_filter
    from ..filters.kalman import optimal_kbf
    from ..model import Model
    from ..riccati import kalman_bucy
    from ..scenario.cost import filter_costs
    from ..scenario.tuning import paper_nu

    model = Model.from_w(res.alpha, res.w, 20.0, res.m)
    specs = {row.name: res.filter(row.columns[0], model) for row in tab.rows if row.role == "tuned"}
    specs["kbf"] = optimal_kbf(model, kalman_bucy(model))
    specs["isl_a31"] = isl_filter(model, paper_nu(model, res.alpha, res.m, res.w)[0])
    costs = filter_costs(model, [dataclasses.replace(s, name=n) for n, s in specs.items()])
    meta = {"how": costs.how, "loop_with_clairvoyant_kbf_isl_ns_per_step": costs.base, "model_sigma": 20.0}
    return costs.ns_per_step, meta


def _table_out(args: argparse.Namespace, res: Tuning) -> int:
    from ..scenario.heldout import held_out
    from ..scenario.table import table_from
    from .scenario_rows import beyond_data, table_rows

    report = held_out(
        res, args.n_report_seeds, execution=_execution(args, "held-out runs", quiet=args.quiet or args.json)
    )
    assert report is not None  # computed when not cached
    tab = table_from(res, args.level, report)
    ns, cost_meta = _costs(res, tab, args)
    keys = [_cell_key(res, c) for c in range(len(res.cells))]
    rows = table_rows(res, tab, keys, ns)
    winners = [
        {
            "cell": k,
            "winner": tab.rows[tab.winner[c]].name,
            "runner_up": tab.rows[tab.runner_up[c]].name,
            "margin": tab.margin[c],
            "margin_low95": tab.margin_low[c],
            "tie": bool(tab.tie[c]),
        }
        for c, k in enumerate(keys)
    ]
    check = {k: bool(tab.stats.low[0, c] <= 1.0 <= tab.stats.high[0, c]) for c, k in enumerate(keys)}
    if args.csv is not None:
        write_csv(
            args.csv,
            nan_to_none(
                [
                    {
                        "filter": row["name"],
                        "label": row["label"],
                        "role": row["role"],
                        "tuning": json.dumps(row["tuning"], ensure_ascii=False),
                        "cell": k,
                        **{a: b for a, b in row["cells"][k].items() if a != "coordinates"},
                        **{f"X{i + 1}": v for i, v in enumerate(row["cells"][k]["coordinates"])},
                    }
                    for row in rows
                    for k in keys
                ]
            ),
        )
    if args.json:
        meta = {
            **_meta(res),
            "report_seeds": [report.seeds[0], report.seeds[-1]],
            "seeds_disjoint": not set(report.seeds) & set(res.seeds),
            "held_out_origin": report.origin,
            "level": tab.level,
            "cells": [
                {
                    "cell": k,
                    "scenario": res.presets[p],
                    "period": per.name,
                    "label": per.label,
                    "from": per.start,
                    "to": per.end,
                }
                for k, (p, per) in zip(keys, res.cells, strict=True)
            ],
            "clairvoyant_reads_1_within_its_interval": check,
            "cost": cost_meta,
        }
        print(
            json.dumps(
                nan_to_none({"meta": meta, "rows": rows, "winners": winners, "beyond": beyond_data(tab)}),
                indent=1,
                allow_nan=False,
                ensure_ascii=False,
            )
        )
        return 0
    _print_table(res, tab, keys, ns, cost_meta, check)
    return 0


def _print_head(res: Tuning, tab: ScenarioTable) -> None:
    """The table's first lines: what a cell is, the seeds, the model, the reading rate, the tuning, knobs at an end."""
    from ..scenario.tuning import FAMILIES

    seeds = tab.seeds[0]
    print(
        f"fair table: the RMSE ratio to the clairvoyant Kalman filter per period at the worst coordinate (Xi), pooled "
        f"over the report seeds {seeds[0]}-{seeds[-1]} (held out: the tuning used seeds {res.seeds[0]}-"
        f"{res.seeds[-1]}; the oracle rows are read on those), {100 * tab.level:g} % Student interval over the "
        f"seeds; alpha = {res.alpha:g}, m = {res.m}, w = {res.w:g}, horizon {res.horizon:g}/r_min; "
        + (
            f"every filter reads the sensor {res.rate:g} times per 1/r_min at sigma(0)"
            if res.rate is not None
            else "every filter reads the sensor at every Euler step"
        )
    )
    print(f"tuned rows: every family at its minimax knob; {res.origin}")
    edges = {f: res.on_edge(f) for f in FAMILIES if res.on_edge(f)}
    if edges:
        print(
            "minimax at a grid's end (no bracketed optimum): "
            + "; ".join(f"{f} {', '.join(f'{k} {v}' for k, v in e.items())}" for f, e in edges.items())
        )


def _print_table(
    res: Tuning,
    tab: ScenarioTable,
    keys: Sequence[str],
    ns: Mapping[str, float],
    cost_meta: Mapping[str, Any],
    check: Mapping[str, bool],
) -> None:
    from ..scenario.table import knob_text

    _print_head(res, tab)
    st = tab.stats
    for p, name in enumerate(res.presets):
        cells = res.preset_cells(p)
        print(
            f"\n{name}: {res.preset_labels[p]}   (W readings = W x {res.reading_time[p]:.3g}/r_min; "
            f"h = {res.h[p]:.3g}, {res.substeps[p] if res.substeps else 1} steps a reading)"
        )
        print(f"  {'filter':64}" + "".join(f" | {res.cells[c][1].label[:26]:>26}" for c in cells))
        for r, row in enumerate(tab.rows):
            label = (
                row.label
                if row.role != "oracle"
                else f"{row.name}: {knob_text(cast('tuple[dict[str, Any], ...]', row.tuning)[p])}"
            )
            print(
                f"  {label[:64]:64}"
                + "".join(
                    f" | {f'{_ratio(st.ratio[r, c])} [{_ratio(st.low[r, c])}, {_ratio(st.high[r, c])}]':>26}"
                    f" X{st.coordinate[r, c] + 1}"
                    for c in cells
                )
            )
    print(
        "\nout of sample (worst cell): on the tuning's seeds [interval] -> on the report seeds; the worst seed's own "
        "ratio and the most seeds above 2x in one cell; FLAGGED where the held-out figure leaves the tuning interval:"
    )
    for r, row in enumerate(tab.rows):
        if row.role in ("tuned", "paper"):
            c = int(np.argmax(np.where(np.isnan(st.worst_seed[r]), np.inf, st.worst_seed[r])))
            print(
                f"  {row.name:14} {_ratio(tab.tuned_figure[r])} [{_ratio(tab.tuned_low[r])}, "
                f"{_ratio(tab.tuned_high[r])}] -> {_ratio(tab.held_figure[r])} "
                f"({tab.held_figure[r] / tab.tuned_figure[r]:.2f}x); worst seed {st.worst_seed_id[r, c]} reads "
                f"{_ratio(st.worst_seed[r, c])} in {keys[c]}; {int(st.above2[r].max())} seeds above 2x in one cell"
                f"{'; FLAGGED' if tab.flagged[r] else ''}; sigma range: {row.assumes}"
            )
    print(
        "\nwho wins each cell (the lowest of the tuned and paper rows; a tie where the paired margin's lower bound "
        "is <= 1):"
    )
    for c, k in enumerate(keys):
        w, r = tab.rows[tab.winner[c]].name, tab.rows[tab.runner_up[c]].name
        m, lo = tab.margin[c], tab.margin_low[c]
        print(
            f"  {k}: "
            + (
                f"tie, {w} and {r} ({m:.2f}x, lower bound {lo:.2f}x)"
                if tab.tie[c]
                else f"{w}, {m:.2f}x ahead of {r} (lower bound {lo:.2f}x)"
            )
        )
    from .scenario_rows import print_beyond

    print_beyond(tab, _ratio)
    print(
        "the clairvoyant filter reads 1 within its interval in "
        + ("every cell" if all(check.values()) else "every cell but " + ", ".join(k for k, v in check.items() if not v))
    )
    if ns:
        print(
            f"cost, ns per step ({cost_meta['how']}): "
            + ", ".join(f"{n} {v:.0f}" for n, v in ns.items())
            + f"; the loop with its three filters {cost_meta['loop_with_clairvoyant_kbf_isl_ns_per_step']:.0f}"
        )


def _tune_out(args: argparse.Namespace, res: Tuning) -> int:
    from ..scenario.table import knob_text
    from ..scenario.tuning import FAMILIES

    r, lo, hi = res.stats(args.level)
    keys = [_cell_key(res, c) for c in range(len(res.cells))]
    best = {f: res.minimax(f) for f in FAMILIES}
    oracle = {f: [res.oracle(f, p) for p in range(len(res.presets))] for f in FAMILIES}
    curves = []
    for f in FAMILIES:
        for j in res.variants(f):
            knob = res.knobs[j]
            for c, k in enumerate(keys):
                p = res.cells[c][0]
                curves.append(
                    {
                        "family": f,
                        "variant": res.names[j],
                        **knob,
                        **({"memory_over_r_min": knob["memory"] * res.reading_time[p]} if "memory" in knob else {}),
                        "cell": k,
                        "ratio": r[j, c],
                        "low": lo[j, c],
                        "high": hi[j, c],
                        "minimax": bool(j == best[f]),
                        "oracle": bool(j == oracle[f][p]),
                    }
                )
    summary = {
        f: {
            "minimax": {
                "knob": res.knobs[best[f]],
                "worst": float(r[best[f]].max()),
                "worst_cell": keys[int(r[best[f]].argmax())],
            },
            "oracle": {
                name: {"knob": res.knobs[oracle[f][p]], "worst": float(r[oracle[f][p], res.preset_cells(p)].max())}
                for p, name in enumerate(res.presets)
            },
        }
        for f in FAMILIES
    }
    if args.csv is not None:
        fields = sorted(
            {k for row in curves for k in row}, key=lambda k: list(curves[0]).index(k) if k in curves[0] else 99
        )
        write_csv(args.csv, nan_to_none([{k: row.get(k) for k in fields} for row in curves]))
    if args.json:
        print(
            json.dumps(
                nan_to_none({"meta": _meta(res), "tuned": summary, "curves": curves}),
                indent=1,
                allow_nan=False,
                ensure_ascii=False,
            )
        )
        return 0
    print(
        f"tuning curves: each variant's largest ratio over each scenario's periods, and over all (the minimax rule "
        f"picks the least of these, *; + the best for that scenario alone); {res.origin}"
    )
    for f in FAMILIES:
        idx = res.variants(f)
        print(f"\n{f}:  {'knob':38}" + "".join(f" | {n[:10]:>10}" for n in res.presets) + " |   all")
        for j in idx:
            marks = ["+" if j == oracle[f][p] else " " for p in range(len(res.presets))]
            vals = [r[j, res.preset_cells(p)].max() for p in range(len(res.presets))]
            print(
                f"{'*' if j == best[f] else ' '} {knob_text(res.knobs[j])[:44]:44}"
                + "".join(f" | {_ratio(v):>9}{mk}" for v, mk in zip(vals, marks, strict=True))
                + f" | {_ratio(r[j].max()):>6}"
            )
    return 0
