"""A/B of the compiled kernel against the one of an earlier git revision, on the same work (ns per step).

    PYTHONPATH=. python benchmarks/bench_kernel_ab.py [--base 44a0182] [--steps 1000000] [--repeats 9]

The base revision's ``isl_core/kernels.py`` is written to a temporary package and compiled there; both kernels
then advance m = 3, truth + Kalman–Bucy + ISL (paper A, Fig. 3, σ = 20) by ``--steps`` steps, interleaved
(A, B, A, B, …) so that load bursts on a shared machine hit both alike, and timed by the thread's CPU time
(``time.thread_time``), which leaves out the time the thread waits for a core. Prints medians and best
times, and the current kernel with an adaptive Kalman–Bucy filter added (the cost of that filter alone).

The default base, 44a0182, is the last kernel that integrated the truth and the estimates in state coordinates
(arguments ``x, z, …, X_out, Z_out, S_out, store``); the current one integrates the errors (:ref:`error-coordinates`;
arguments ``x, e, …, X_out, E_out, S_out, store, out0``). Both are timed without storing trajectories (the long-run
mode), which is where the current kernel advances only X_m of the truth.
"""

from __future__ import annotations

import argparse
import importlib.util
import inspect
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from isl_core import Model, isl_filter, kalman_bucy, optimal_kbf, step_size
from isl_core._engine import draw_start, initial_state, pack
from isl_core.filters.adaptive import adaptive_kbf
from isl_core.kernels import advance
from isl_core.kernels.bundles import Batches, Grid, Trajectory

FIG3 = Model(0.5, 3.0, 20.0, 3)
ROOT = Path(__file__).resolve().parents[1]


def _load_base(rev: str, where: Path):
    src = subprocess.run(
        ["git", "-C", str(ROOT), "show", f"{rev}:isl_core/kernels.py"], check=True, capture_output=True, text=True
    ).stdout
    (where / "kernels_base.py").write_text(src, "utf-8")
    spec = importlib.util.spec_from_file_location("kernels_base", where / "kernels_base.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.advance


def _specs(adaptive: bool):
    kb = kalman_bucy(FIG3)
    specs = [optimal_kbf(FIG3, kb), isl_filter(FIG3, 3.0)]
    h = step_size(FIG3, kb, specs)
    return specs + ([adaptive_kbf(FIG3)] if adaptive else []), h


def run_current(n: int, adaptive: bool = False) -> float:
    specs, h = _specs(adaptive)
    rng = np.random.default_rng(1)
    x, e0 = draw_start(FIG3, kalman_bucy(FIG3), rng, "stationary")
    e = np.tile(e0, (len(specs), 1))
    na = int(adaptive)
    t0 = time.thread_time()
    advance(
        x,
        e,
        rng,
        n,
        0,
        Grid(h, FIG3.alpha, FIG3.beta),
        FIG3.sigma,
        pack(FIG3, specs),
        Batches(0, n, np.zeros((1, len(specs), 3)), np.zeros((1, na))),
        Trajectory.none(len(specs), na, 3),
    )
    return (time.thread_time() - t0) / n * 1e9


def run_base(base, n: int) -> float:
    """The base kernel on the same work: the state-coordinate signature of 44a0182 (kind/table/ad), or the older
    KBF+ISL one (damp/coef/power) of fca86cd."""
    specs, h = _specs(False)
    rng = np.random.default_rng(1)
    x, z = initial_state(FIG3, rng), np.zeros((2, 3))
    params = inspect.signature(base.py_func).parameters
    t0 = time.thread_time()
    if "kind" in params:
        base(
            x,
            z,
            rng,
            n,
            h,
            FIG3.alpha,
            FIG3.beta,
            FIG3.sigma,
            *pack(FIG3, specs),
            0,
            0,
            n,
            np.zeros((1, 2, 3)),
            np.zeros((1, 0)),
            np.empty((1, 3)),
            np.empty((2, 1, 3)),
            np.empty((0, 1)),
            False,
        )
    else:
        damp = np.array([f.damp for f in specs])
        coef = np.array([f.coef for f in specs])
        power = np.array([f.power for f in specs])
        base(
            x,
            z,
            rng,
            n,
            h,
            FIG3.alpha,
            FIG3.beta,
            FIG3.sigma,
            damp,
            coef,
            power,
            0,
            0,
            n,
            np.zeros((1, 2, 3)),
            np.empty((1, 3)),
            np.empty((2, 1, 3)),
            False,
        )
    return (time.thread_time() - t0) / n * 1e9


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="44a0182", help="git revision of the baseline kernel")
    parser.add_argument("--steps", type=int, default=1_000_000)
    parser.add_argument("--repeats", type=int, default=9)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        base = _load_base(args.base, Path(tmp))
        assert "z" in inspect.signature(base.py_func).parameters, "the base kernel must be a state-coordinate one"
        run_base(base, 1000)  # compile
        run_current(1000)
        run_current(1000, adaptive=True)
        times = {"base": [], "current": [], "current + adaptive KBF": []}
        for _ in range(args.repeats):
            times["base"].append(run_base(base, args.steps))
            times["current"].append(run_current(args.steps))
            times["current + adaptive KBF"].append(run_current(args.steps, adaptive=True))
    print(
        f"m = 3, truth + KBF + ISL (Fig. 3, σ = 20), {args.steps:,} steps × {args.repeats} interleaved repeats, "
        "thread CPU time, "
        f"base = {args.base} (load average {os.getloadavg()[0]:.2f}, python {sys.version.split()[0]}):"
    )
    for name, ts in times.items():
        print(f"    {name:24s} median {statistics.median(ts):7.1f} ns/step   best {min(ts):7.1f}")
    ratio = [c / b for b, c in zip(times["base"], times["current"], strict=True)]
    print(
        f"    current/base per interleaved pair: median {statistics.median(ratio):.3f} "
        f"(range {min(ratio):.3f}..{max(ratio):.3f})"
    )


if __name__ == "__main__":
    main()
