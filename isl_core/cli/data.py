"""``isl data SOURCE``: fit the model to a recorded series, run every filter, judge them on a held-out tail
(:ref:`data-cli`).

    isl data SOURCE [--m M] [--alpha A] [--time COL --value COL] [--holdout F] [--nu NU] [--json]

SOURCE is a shipped data set (``nile``, ``co2``, ``long``) or a CSV file. Prints ``fit`` (m, α, β, σ — (A.19)'s,
σ_r·√Δ̄ — and σ_r, their standard errors, log L, AIC, BIC, fitted on the readings before the held-out tail),
``orders`` (AIC and BIC per m when m is chosen) and each filter's ``diagnostics``
(:mod:`isl_core.series.diagnostics`). Bad input ends with one line naming the argument and exit code 2.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .commands import UsageError, nan_to_none

if TYPE_CHECKING:
    from isl_core.series.diagnostics import Judgement
    from isl_core.series.record import Series

__all__ = ["add_data", "cmd_data", "summary"]


def add_data(
    sub: argparse._SubParsersAction[Any],
    positive: Callable[[str], float],
    nonneg: Callable[[str], float],
    whole: Callable[[str], int],
) -> argparse.ArgumentParser:
    """Add ``isl data`` to argparse's sub-parsers ``sub``, with the parser's number types."""
    p: argparse.ArgumentParser = sub.add_parser(
        "data", help="a recorded series: the model fitted, every filter run and judged"
    )
    p.add_argument("source", metavar="SOURCE", help="a shipped data set (nile, co2, long) or a CSV file")
    p.add_argument("--m", type=whole, default=None, help="the model's order 1..6 (default: chosen by BIC)")
    p.add_argument("--alpha", type=nonneg, default=None, help="α fixed (default: fitted)")
    p.add_argument("--time", default=None, metavar="COL", help="the CSV's time column (default the first)")
    p.add_argument("--value", default=None, metavar="COL", help="the CSV's value column (default the second)")
    p.add_argument("--holdout", type=positive, default=0.2, help="share of the times held out (default 0.2)")
    p.add_argument("--nu", type=positive, default=None, help="the ISL filters' ν (default the fitted β)")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=cmd_data)
    return p


def _load(args: argparse.Namespace) -> Series:
    from isl_core.series.sources import DATASETS, dataset, read_csv

    if args.source in DATASETS:
        if args.time is not None or args.value is not None:
            raise UsageError("isl data: error: --time and --value choose a CSV file's columns, not a data set's")
        return dataset(args.source)
    return read_csv(args.source, time=args.time, value=args.value)


def _table(out: dict[str, Any]) -> str:
    f = out["fit"]
    lines = [
        f"{out['source']}: {out['readings']} readings, fit on the first {out['split']} times, judged on the rest",
        f"fit: m = {f['m']}, α = {f['alpha']:.6g} ± {f['alpha_se']:.3g}, β = {f['beta']:.6g} ± {f['beta_se']:.3g},"
        f" σ = {f['sigma']:.6g} ± {f['sigma_se']:.3g} (σ_r = {f['sigma_r']:.6g}); log L = {f['loglik']:.6f},"
        f" AIC = {f['aic']:.3f}, BIC = {f['bic']:.3f}",
        f"{'filter':<14}{'RMSE':>12}{'NIS':>9}{'NIS 95 % range':>18}{'Ljung–Box p':>13}{'pred. log L':>13}",
    ]
    for d in out["diagnostics"]:
        lo, hi = d["nis_interval"]
        lines.append(
            f"{d['name']:<14}{d['rmse']:>12.5g}{d['nis']:>9.3f}{f'[{lo:.3f}, {hi:.3f}]':>18}"
            f"{d['ljung_box_p']:>13.3g}{d['predictive_loglik']:>13.2f}"
        )
    return "\n".join(lines).replace("nan", "—")


def summary(series: Series, judgement: Judgement) -> dict[str, Any]:
    """What ``isl data --json`` prints for ``judgement`` (:func:`isl_core.series.judge`) of ``series``: the source,
    the readings, the split, ``fit``, ``orders``, ``nu`` and ``diagnostics`` (NaN where a number does not exist)."""
    j = judgement
    return {
        "source": series.name,
        "readings": int(series.present.sum()),
        "split": j.split,
        "fit": j.fit.as_dict(),
        "orders": [{k: f.as_dict()[k] for k in ("m", "loglik", "aic", "bic")} for f in j.orders],
        "nu": j.run.nu,
        "diagnostics": [d.as_dict() for d in j.diagnostics],
    }


def cmd_data(args: argparse.Namespace) -> int:
    """Fit, run and judge (module docstring); print the result."""
    try:
        from isl_core.series.diagnostics import judge

        s = _load(args)
        j = judge(s, m=args.m, alpha=args.alpha, holdout=args.holdout, nu=args.nu)
    except ImportError as exc:
        raise UsageError(f"isl data: error: {exc}") from None
    except ValueError as exc:
        raise UsageError(f"isl data: error: {exc}") from None
    out = summary(s, j)
    if args.json:
        print(json.dumps(nan_to_none(out), indent=2, allow_nan=False))
    else:
        print(_table(out))
    return 0
