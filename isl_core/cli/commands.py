"""The compute commands of ``isl`` (run, sweep, recommend, worstcase; scenario: :mod:`isl_core.cli.scenario`):
what each computes through the core's public functions and how it prints or writes the result. The command line
itself (arguments, exit codes) is :mod:`isl_core.cli.parser`.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from isl_core.model import Model
    from isl_core.worstcase import WorstCaseTable

_V = TypeVar("_V")

__all__ = [
    "UsageError",
    "cmd_recommend",
    "cmd_run",
    "cmd_sweep",
    "cmd_worstcase",
    "flat",
    "nan_to_none",
    "progress_bar",
    "write_csv",
]


class UsageError(Exception):
    """Bad command-line arguments: reported in one line, exit code 2."""


def write_csv(path: str | Path, rows: list[dict[str, Any]]) -> None:
    """``rows`` (dicts with the same keys) as a UTF-8 CSV file with a header row."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def progress_bar(label: str, enabled: bool) -> Callable[[float], None] | None:
    """A text progress bar on stderr (callback for :func:`isl_core.sweep`); None when disabled."""
    if not enabled:
        return None
    start = time.perf_counter()
    state = {"shown": -1}

    def update(fraction: float) -> None:
        pct = int(100 * min(max(fraction, 0.0), 1.0))
        if pct == state["shown"]:
            return
        state["shown"] = pct
        bar = "#" * (pct // 4) + "." * (25 - pct // 4)
        end = "\n" if pct == 100 else ""
        sys.stderr.write(f"\r{label} [{bar}] {pct:3d}% {time.perf_counter() - start:6.1f} s{end}")
        sys.stderr.flush()

    return update


def _client(address: str | None) -> Any:  # a dask.distributed Client (untyped)
    if address is None:
        return None
    try:
        from distributed import Client
    except ModuleNotFoundError:
        raise UsageError("isl sweep: error: --dask needs the optional extra: pip install 'isl[dask]'") from None
    return Client(address)  # type: ignore[no-untyped-call]  # distributed is untyped


def _model(args: argparse.Namespace) -> Model:
    from isl_core import Model

    if args.beta is not None:
        return Model(args.alpha, args.beta, args.sigma, args.m)
    if args.alpha == 0:
        raise UsageError("isl run: error: alpha = 0 needs --beta (w = β/√(2α) is undefined)")
    return Model.from_w(args.alpha, args.w, args.sigma, args.m)


def cmd_run(args: argparse.Namespace) -> int:
    """One trajectory: s (theory), ŝ and š (measured), ratios and the predicted ratio, r_min, h, T."""
    from isl_core import predicted_ratios, simulate

    model = _model(args)
    nu = model.beta if args.nu is None else args.nu
    run = simulate(model, nu, horizon=args.horizon, seed=args.seed)
    theory = predicted_ratios(model, nu)
    out = {
        "model": {"alpha": model.alpha, "beta": model.beta, "sigma": model.sigma, "m": model.m},
        "nu": nu,
        "seed": args.seed,
        "s": run.s.tolist(),
        "s_hat": run.s_hat.tolist(),
        "s_check": run.s_check.tolist(),
        "ratio_hat": run.ratio_hat.tolist(),
        "ratio_check": run.ratio_check.tolist(),
        "theory_ratio_check": theory.tolist(),
        "r_min": run.r_min,
        "h": run.h,
        "T": run.T,
        "N": run.N,
        "window": {
            "from_t": 0.0,
            "to_t": run.T,
            "burn_in": 0.0,
            "horizon_over_r_min": run.horizon,
            "requested_horizon_over_r_min": args.horizon,
            "lengthened_by": run.stretch,
            "start": run.start,
        },
    }
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    print(
        f"alpha = {model.alpha:g}, beta = {model.beta:.4g}, sigma = {model.sigma:g}, m = {model.m}, nu = {nu:.4g}, "
        f"seed = {args.seed}"
    )
    longer = (
        ""
        if run.stretch == 1.0
        else (f", lengthened ×{run.stretch:.3g} from {args.horizon:g}/r_min: the ISL filter settles slower (B.46)")
    )
    print(f"r_min = {run.r_min:.4g}, T = {run.T:.4g} ({run.horizon:.4g}/r_min{longer}), h = {run.h:.3g}, N = {run.N:,}")
    print(
        f"averaging window: t in [0, T], no burn-in; every filter starts at X(0) - e0, e0 ~ N(0, Delta) "
        f"(start = {run.start})"
    )
    print(f"{'i':>2} {'s_i (theory)':>13} {'ŝ_i (KBF)':>11} {'š_i (ISL)':>11} {'ŝ/s':>7} {'š/s':>7} {'š/s theory':>11}")
    for i in range(model.m):
        print(
            f"{i + 1:>2} {run.s[i]:13.4g} {run.s_hat[i]:11.4g} {run.s_check[i]:11.4g} {run.ratio_hat[i]:7.3f} "
            f"{run.ratio_check[i]:7.3f} {theory[i]:11.3f}"
        )
    print("ŝ, š measured along this one trajectory (A.30); a short run gives noisy ratios — raise --horizon.")
    return 0


def nan_to_none(obj: Any) -> Any:
    """JSON has no nan/inf: map them to null, recursively."""
    if isinstance(obj, dict):
        return {k: nan_to_none(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [nan_to_none(v) for v in obj]
    return None if isinstance(obj, float) and not math.isfinite(obj) else obj


def cmd_sweep(args: argparse.Namespace) -> int:
    """Paper A's Fig. 2 grid by default; writes fig2.csv and fig2.json into --out (and the figures an extension of
    ``isl`` adds, see :class:`isl_core.cli.Extension`)."""
    from isl_core import Execution, Sampling, sweep

    if args.ell_min > args.ell_max:
        raise UsageError("isl sweep: error: --ell-min must be <= --ell-max")
    nob = [2.0**ell for ell in range(args.ell_min, args.ell_max + 1)]
    client = _client(args.dask)
    try:
        res = sweep(
            args.alphas,
            args.sigmas,
            nob,
            m=args.m,
            w=args.w,
            beta=args.beta,
            sampling=Sampling(args.seeds, args.horizon, batches=args.batches),
            execution=Execution(args.workers, client, progress=progress_bar("sweep", not args.quiet)),
        )
    finally:
        if client is not None:
            client.close()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = nan_to_none(res.records())
    write_csv(out / "fig2.csv", rows)
    meta = {
        "m": res.m,
        "w": None if res.beta is not None else res.w,
        "beta": res.beta,
        "horizon_over_r_min": res.horizon,
        "burn_in_over_r_min": res.burn,
        "lengthened_by": res.stretch.tolist(),
        "seeds": list(res.seeds),
        "batches": res.batches,
        "level": res.level,
        "alphas": res.alphas.tolist(),
        "sigmas": res.sigmas.tolist(),
        "nu_over_beta": res.nu_over_beta.tolist(),
    }
    (out / "fig2.json").write_text(json.dumps({"meta": meta, "rows": rows}, indent=1, allow_nan=False), "utf-8")
    written = [out / "fig2.csv", out / "fig2.json"]
    figures = getattr(args, "figures", None)  # the dashboard's HTML and PNG
    if figures is not None:
        written += figures(res, out, args)
    kbf = res.kbf_ratio
    print(
        f"{res.ratio.size:,} ratios over {len(res.alphas)}×{len(res.sigmas)}×{len(nob)} configurations; "
        f"Kalman–Bucy's own ratio spans {kbf.min():.3f}..{kbf.max():.3f} (should be ≈ 1)"
    )
    print(_window_line(res.horizon, res.stretch.ravel().tolist(), res.seeds))
    for p in written:
        print(f"wrote {p}")
    return 0


def _fmt(values: Iterable[float]) -> str:
    return "[" + ", ".join(f"{v:.3f}" for v in values) + "]"


def cmd_recommend(args: argparse.Namespace) -> int:
    """Recommended ν per α (min over ν of the worst case over σ and i), beside paper A's table (A.31)."""
    from isl_core import Execution, Sampling, recommend_nu
    from isl_core.paper import a31_nu_over_beta

    recs = []
    progress = progress_bar("verify", not args.quiet and not args.no_verify and not args.json)
    for k, alpha in enumerate(args.alphas):
        paper = a31_nu_over_beta(alpha, args.m, args.w)  # table (A.31), as published
        sub = None if progress is None else (lambda f, k=k: progress((k + f) / len(args.alphas)))
        recs.append(
            recommend_nu(
                alpha,
                sigmas=args.sigmas,
                m=args.m,
                w=args.w,
                verify=not args.no_verify,
                compare=[] if paper is None else [paper],
                sampling=Sampling(args.seeds, args.horizon, batches=args.batches),
                execution=Execution(progress=sub),
            )
        )
    if args.json:
        rows = []
        for r in recs:
            row = {k: v for k, v in vars(r).items() if k != "compared"}
            row["sigmas"] = list(r.sigmas)
            row["paper_a31"] = [vars(c) for c in r.compared]
            rows.append(row)
        print(json.dumps(nan_to_none(rows), indent=2, allow_nan=False))
        return 0
    how = "predicted (theory) only" if args.no_verify else "simulated with a 95 % interval"
    print(f"worst case over sigma in {list(args.sigmas)} and i = 1..{args.m} (m = {args.m}, w = {args.w:g}); {how}")
    print(
        f"{'alpha':>6} {'nu/beta':>8} {'nu':>8} {'theory':>7} {'simulated':>22} {'at (σ, i)':>11} "
        f"{'best fixed KBF':>15} | {'paper (A.31)':>12} {'theory':>7} {'simulated':>9}"
    )
    for r in recs:
        sim = (
            "—"
            if math.isnan(r.simulated_worst)
            else f"{r.simulated_worst:.3f} [{r.simulated_low:.3f}, {r.simulated_high:.3f}]"
        )
        line = (
            f"{r.alpha:6g} {r.nu_over_beta:8.4f} {r.nu:8.4f} {r.theory_worst:7.3f} {sim:>22} "
            f"{f'({r.worst_sigma:g}, {r.worst_i})':>11} {r.kbf_worst:15.3f} | "
        )
        if r.compared:
            c = r.compared[0]
            csim = "—" if math.isnan(c.simulated) else f"{c.simulated:.3f}"
            line += f"{c.nu_over_beta:12g} {c.theory:7.3f} {csim:>9}"
        else:
            line += f"{'—':>12}"
        print(line)
    print("best fixed KBF: a Kalman–Bucy filter designed for one sigma, its worst case over the range (theory).")
    print(
        "paper (A.31): the nu/beta of paper A's table, as published (read off its Fig. 2), simulated on the same noise."
    )
    if not args.no_verify:
        print(_window_line(args.horizon, [s for r in recs for s in r.stretch], args.seeds))
    return 0


def _window_line(horizon: float, stretch: Sequence[float], seeds: Iterable[int]) -> str:
    """Where a simulated table averages: the burn-in and the window, in 1/r_min, lengthened for the slowest filter."""
    from isl_core import SWEEP_BURN

    lo, hi = (min(stretch), max(stretch)) if len(stretch) else (1.0, 1.0)
    span = f"×{lo:.3g}" if lo == hi else f"×{lo:.3g} to ×{hi:.3g}"
    return (
        f"averaging window of each simulated run: a burn-in of {SWEEP_BURN:g}/r_min, then {horizon:g}/r_min, both "
        f"lengthened {span} where a filter settles slower than the optimal one (B.46); seeds {list(seeds)}; "
        f"filters start at X(0) - e0, e0 ~ N(0, Delta)"
    )


def flat(values: Iterable[Iterable[_V]]) -> list[_V]:
    """``nargs="+"`` of comma-separated lists → one flat list."""
    return [x for group in values for x in group]


def cmd_worstcase(args: argparse.Namespace) -> int:
    """Worst-case RMSE ratio over a σ range per α (rows) and filter (columns): simulated, with theory beside it."""
    from isl_core import Candidates, Execution, Sampling, worst_case

    bar = progress_bar("worstcase", not (args.quiet or args.json))
    client = _client(args.dask)
    try:
        res = worst_case(
            flat(args.alphas),
            sigma_range=(args.sigma_min, args.sigma_max),
            n_sigma=args.n_sigma,
            m=args.m,
            w=args.w,
            candidates=Candidates(tuple(flat(args.filters)), args.sigma_design, args.memory),
            sampling=Sampling(tuple(flat(args.seeds)), args.horizon, batches=args.batches),
            execution=Execution(args.workers, client, progress=bar),
        )
    finally:
        if client is not None:
            client.close()
    if args.json:
        meta = {
            "m": res.m,
            "w": res.w,
            "horizon_over_r_min": res.horizon,
            "burn_in_over_r_min": res.burn,
            "lengthened_by": res.stretch.tolist(),
            "seeds": list(res.seeds),
            "batches": res.batches,
            "level": res.level,
            "alphas": res.alphas.tolist(),
            "sigmas": res.sigmas.tolist(),
            "filters": list(res.names),
            "labels": list(res.labels),
            "best_fixed_kbf_worst": res.best_fixed_worst.tolist(),
            "best_fixed_kbf_sigma": res.best_fixed_sigma.tolist(),
        }
        print(json.dumps(nan_to_none({"meta": meta, "rows": res.records()}), indent=1, allow_nan=False))
        return 0
    _print_worstcase(res)
    return 0


def _ratio(x: float) -> str:
    """A ratio with 4 significant digits below 100 (``1.014``, ``18.99``), so a row's numbers compare digit by digit."""
    return f"{x:.3f}" if x < 10 else f"{x:.2f}" if x < 100 else f"{x:.4g}"


def _print_worstcase(res: WorstCaseTable) -> None:
    worst, low, high, theory = res.worst, res.worst_low, res.worst_high, res.theory_worst
    width = [max(len(label), 20) for label in res.labels]
    head = f"{'alpha':>6} | " + " | ".join(f"{label:>{w}}" for label, w in zip(res.labels, width, strict=False))
    lo, hi = res.sigma_range
    print(
        f"worst case of the RMSE ratio š_i/s_i over sigma in [{lo:g}, {hi:g}] ({len(res.sigmas)} log-spaced values) "
        f"and i = 1..{res.m}; m = {res.m}, w = {res.w:g}, horizon {res.horizon:g}/r_min x seeds {list(res.seeds)}"
    )
    print(f"simulated, max over (sigma, i) with its {100 * res.level:g} % interval:")
    print(head)
    for a, alpha in enumerate(res.alphas):
        cells = []
        for f, w in enumerate(width):
            if res.names[f] == "isl_a31" and math.isnan(res.nu[a, f]):
                cell = "not in (A.31)"
            elif math.isnan(worst[a, f]):
                cell = "diverged"
            else:
                cell = f"{_ratio(worst[a, f])} [{_ratio(low[a, f])}, {_ratio(high[a, f])}]"
            cells.append(f"{cell:>{w}}")
        print(f"{alpha:6g} | " + " | ".join(cells))
    print("theory (exact Lyapunov for the fixed-gain Kalman–Bucy filters, statistical linearization for ISL; — none):")
    print(head)
    for a, alpha in enumerate(res.alphas):
        cells = [f"{'—' if math.isnan(theory[a, f]) else _ratio(theory[a, f]):>{w}}" for f, w in enumerate(width)]
        print(f"{alpha:6g} | " + " | ".join(cells))
    tunings = []
    for f, name in enumerate(res.names):
        if name in ("isl", "isl_model", "isl_a31"):
            pairs = zip(res.nu[:, f], res.alphas, strict=False)
            tunings.append(
                f"{name} nu/beta = " + ", ".join(f"{nu / (res.w * math.sqrt(2.0 * alpha)):.3g}" for nu, alpha in pairs)
            )
        elif name in ("kbf_mismatched", "kbf_minimax"):
            tunings.append(f"{name} sigma_design = {res.sigma_design[0, f]:g}")
    if tunings:
        print("tunings (per alpha): " + "; ".join(tunings))
    print(
        "best fixed-gain KBF over the range (theory): worst "
        + ", ".join(f"{v:.3f}" for v in res.best_fixed_worst)
        + " at sigma_design "
        + ", ".join(f"{v:.3g}" for v in res.best_fixed_sigma)
    )
    print(_window_line(res.horizon, res.stretch.ravel().tolist(), res.seeds))
