"""Timings of the theory (:ref:`theory`) and of the simulated Fig. 2 sweep (paper A). Prints figures; asserts nothing.

    PYTHONPATH=. python benchmarks/bench_theory_sweep.py [--horizon 1000] [--workers 2] [--serial]

1. ``predicted_ratios`` for one (model, ν): warm (the model's Kalman–Bucy solution cached) and cold (a new σ
   each call, so the CARE is solved too). Target ≤ 1 ms.
2. The full theory grid of Fig. 2 with 111 ν values: 5 α × 3 σ × 111 ν × 3 coordinates. Target ≤ 1 s.
3. The simulated Fig. 2 grid: 165 configurations (5 α × 3 σ × 11 ν), horizon 1000/r_min each after the
   burn-in, one seed, h by the :ref:`step-size` rule over each group's filters, on a local thread pool. Target ≤ 30 s on
   2 cores. "ns per configuration-step" = wall time / Σ_groups (steps × ν values of the group).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from isl_core import Execution, Model, Sampling, predicted_ratios, predicted_ratios_grid, sweep
from isl_core.riccati import _solved as _kb
from isl_core.sweep import FIG2_ALPHAS, FIG2_NU_OVER_BETA, FIG2_SIGMAS


def bench_one(reps: int = 2000) -> None:
    model = Model.from_w(0.5, 3.0, 20.0, 3)
    predicted_ratios(model, 3.0)
    t = time.perf_counter()
    for _ in range(reps):
        predicted_ratios(model, 3.0)
    warm = (time.perf_counter() - t) / reps
    sigmas = 20.0 + np.arange(200) * 1e-3
    t = time.perf_counter()
    for s in sigmas:
        predicted_ratios(Model.from_w(0.5, 3.0, float(s), 3), 3.0)
    cold = (time.perf_counter() - t) / len(sigmas)
    print(
        f"theory, one (model, nu): warm {warm * 1e3:.3f} ms, cold (CARE included) {cold * 1e3:.3f} ms [target <= 1 ms]"
    )


def bench_grid(reps: int = 5) -> None:
    nob = 2.0 ** np.linspace(-8, 2, 111)
    times = []
    for _ in range(reps):
        _kb.cache_clear()
        t = time.perf_counter()
        for alpha in FIG2_ALPHAS:
            for sigma in FIG2_SIGMAS:
                model = Model.from_w(alpha, 3.0, sigma, 3)
                predicted_ratios_grid(model, model.beta * nob)
        times.append(time.perf_counter() - t)
    print(
        f"theory, Fig. 2 grid 5 x 3 x 111 nu x 3 coordinates: best {min(times):.3f} s, median "
        f"{float(np.median(times)):.3f} s over {reps} (cold caches) [target <= 1 s]"
    )


def bench_sweep(horizon: float, workers: int) -> None:
    sweep([1.0], [20.0], [1.0], sampling=Sampling((0,), 5.0))  # compile / load the kernel once
    t = time.perf_counter()
    sampling, execution = Sampling((0,), horizon), Execution(workers)
    res = sweep(FIG2_ALPHAS, FIG2_SIGMAS, FIG2_NU_OVER_BETA, m=3, w=3.0, sampling=sampling, execution=execution)
    wall = time.perf_counter() - t
    steps = int(res.steps.sum())
    config_steps = steps * len(res.nu_over_beta)
    print(
        f"simulated Fig. 2 grid, {res.ratio.shape[0] * res.ratio.shape[1] * res.ratio.shape[2]} configurations, "
        f"horizon {horizon:g}/r_min, {workers} worker thread(s): {wall:.2f} s [target <= 30 s on 2 cores]"
    )
    print(
        f"  {steps:,} time steps in {res.steps.size} groups (truth + Kalman–Bucy + {len(res.nu_over_beta)} ISL "
        f"filters each); {wall / config_steps * 1e9:.2f} ns per configuration-step "
        f"({wall / steps * 1e9 * workers:.0f} ns per group-step per core)"
    )
    print(f"  Kalman–Bucy's own ratio: {res.kbf_ratio.min():.3f} .. {res.kbf_ratio.max():.3f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--horizon", type=float, default=1000.0)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--serial", action="store_true", help="also time the sweep on one thread")
    args = ap.parse_args()
    print(f"cpu count {os.cpu_count()}, load average {os.getloadavg()[0]:.2f} (shared machine: timings are noisy)")
    bench_one()
    bench_grid()
    bench_sweep(args.horizon, args.workers)
    if args.serial:
        bench_sweep(args.horizon, 1)


if __name__ == "__main__":
    main()
