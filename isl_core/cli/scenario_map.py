"""``isl scenario --map KIND``: who wins over a grid of scenarios, printed or written as CSV/JSON
(:func:`isl_core.scenario.map.who_wins_map`)."""

from __future__ import annotations

import argparse
import json
import math

from .commands import UsageError, flat, nan_to_none, progress_bar, write_csv

__all__ = ["scenario_map"]


def scenario_map(args: argparse.Namespace) -> int:
    """``isl scenario --map KIND``: per cell the filter with the lowest ratio to the clairvoyant one, and its margin —
    with the table's tuning (computed if not cached; ``--untuned``: the constructors' defaults)."""
    from ..requests import Execution
    from ..scenario.map import AXIS_LABELS, STEP_AT, who_wins_map
    from ..scenario.tuning import tune

    after = args.horizon - STEP_AT if args.map == "sigma_step" else args.horizon
    if after < args.window:
        raise UsageError(
            f"isl scenario: --horizon must be at least {STEP_AT:g} (the sigma step's time) + --window "
            f"for the sigma_step map, got {args.horizon:g}"
        )
    quiet = args.quiet or args.json
    run = Execution(args.workers, progress=progress_bar("tuning", not quiet), cache=not args.no_cache)
    tuning = None if args.untuned else tune(args.alpha, m=args.m, w=args.w, execution=run, rate=args.rate)
    res = who_wins_map(
        args.map,
        args.alpha,
        values=None if args.values is None else flat(args.values),
        m=args.m,
        w=args.w,
        n_seeds=32 if args.n_seeds is None else args.n_seeds,
        window=args.window,
        after=after,
        burn=args.burn,
        tuning=tuning,
        untuned=args.untuned,
        progress=progress_bar("scenario map", not quiet),
    )
    winner, margin, tie = res.winner, res.margin, res.tie
    rows = [
        {
            "since_step_over_r_min": None if math.isnan(t) else float(t),
            "value": float(x),
            "winner": res.filters[winner[r, c]],
            "margin": float(margin[r, c]),
            "margin_low95": float(res.margin_low[r, c]),
            "tie": bool(tie[r, c]),
            **{f: float(res.ratio[r, c, k]) for k, f in enumerate(res.filters)},
        }
        for r, t in enumerate(res.rows)
        for c, x in enumerate(res.x)
    ]
    if args.csv is not None:
        write_csv(args.csv, rows)
    if args.json:
        meta = {
            "map": res.kind,
            "axis": AXIS_LABELS[res.kind],
            "alpha": res.alpha,
            "beta": res.model.beta,
            "m": res.model.m,
            "sigma0": res.model.sigma,
            "seeds": [res.seeds[0], res.seeds[-1]],
            "origin": res.origin,
            "window_over_r_min": res.window,
            "filters": dict(zip(res.filters, res.labels, strict=True)),
        }
        print(json.dumps(nan_to_none({"meta": meta, "cells": rows}), indent=1, allow_nan=False, ensure_ascii=False))
        return 0
    print(
        f"who wins ({res.kind}): the filter with the lowest period ratio to the clairvoyant Kalman filter "
        f"(coordinates averaged, pooled over {len(res.seeds)} seeds {res.seeds[0]}-{res.seeds[-1]}; rows of "
        f"{res.window:g}/r_min), x its margin over the runner-up, '~' a tie (the paired margin's 95 % lower bound "
        f"is <= 1); alpha = {res.alpha:g}; {res.origin}"
    )
    head = "since step" if res.kind == "sigma_step" else ""
    print(f"{head:>10} | {AXIS_LABELS[res.kind]}: " + " | ".join(f"{x:>18g}" for x in res.x))
    for r, t in enumerate(res.rows):
        cells = [
            f"{'~' if tie[r, c] else ''}{res.filters[winner[r, c]]} x{margin[r, c]:.2f}" for c in range(len(res.x))
        ]
        label = "" if math.isnan(t) else f"{t:g}"
        print(f"{label:>10} | " + " " * (len(AXIS_LABELS[res.kind]) + 2) + " | ".join(f"{c:>18}" for c in cells))
    return 0
