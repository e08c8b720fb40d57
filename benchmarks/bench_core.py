"""Benchmark of the numerical core: kernel speed, cold-start of a fresh process, memory of a long run.

    PYTHONPATH=. python benchmarks/bench_core.py [--steps 1000000] [--repeats 7]

Prints
(a) the warm fused kernel's ns/step for m = 3, truth + Kalman–Bucy + ISL, noise generation included
    (median and best of several repeats of 10⁶ steps), the same through ``simulate_rmse`` and ``simulate``
    (stored trajectories), and the plain-numpy reference's ns/step on fewer steps;
(b) the wall time of a fresh process that imports ``isl_core`` and runs Fig. 3 (σ = 20) with the numba
    cache in place, and whether any compilation happens there or in a later call;
(c) the peak memory (tracemalloc) of ``simulate`` over 10⁶ steps against the bytes of the arrays it returns.
Timings on a shared machine are noisy: compare medians of interleaved runs, and read the load average.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
import tracemalloc

import numpy as np

from isl_core import Model, isl_filter, kalman_bucy, optimal_kbf, simulate, simulate_rmse, step_size
from isl_core._engine import draw_start, pack
from isl_core.kernels import advance
from isl_core.kernels.bundles import Batches, Grid, Trajectory
from isl_core.reference import reference_trajectories

FIG3 = Model(0.5, 3.0, 20.0, 3)  # paper A, Fig. 3 (σ = 20)
NU = 3.0


def _setup():
    kb = kalman_bucy(FIG3)
    specs = [optimal_kbf(FIG3, kb), isl_filter(FIG3, NU)]
    return specs, step_size(FIG3, kb, specs)


def kernel_ns_per_step(n: int) -> float:
    """One call of the compiled kernel over n steps (no trajectories stored), ns per step."""
    specs, h = _setup()
    packed = pack(FIG3, specs)
    rng = np.random.default_rng(1)
    x, e0 = draw_start(FIG3, kalman_bucy(FIG3), rng, "stationary")
    e = np.tile(e0, (2, 1))
    sq = np.zeros((1, 2, 3))
    t0 = time.perf_counter()
    advance(
        x,
        e,
        rng,
        n,
        0,
        Grid(h, FIG3.alpha, FIG3.beta),
        FIG3.sigma,
        packed,
        Batches(0, n, sq, np.empty((1, 0))),
        Trajectory.none(2, 0, 3),
    )
    return (time.perf_counter() - t0) / n * 1e9


def rmse_ns_per_step(n: int) -> float:
    specs, h = _setup()
    t0 = time.perf_counter()
    simulate_rmse(FIG3, specs, T=n * h, h=h, seed=1)
    return (time.perf_counter() - t0) / n * 1e9


def simulate_ns_per_step(n: int) -> float:
    _, h = _setup()
    t0 = time.perf_counter()
    run = simulate(FIG3, NU, T=n * h, h=h, seed=1)
    dt = time.perf_counter() - t0
    assert n == run.N
    return dt / n * 1e9


def reference_ns_per_step(n: int) -> float:
    specs, h = _setup()
    t0 = time.perf_counter()
    reference_trajectories(FIG3, specs, h=h, n=n, seed=1)
    return (time.perf_counter() - t0) / n * 1e9


def part_a(steps: int, repeats: int) -> None:
    kernel_ns_per_step(1000)  # compile or load from cache
    simulate_ns_per_step(1000)
    rows = {
        "kernel (advance)": kernel_ns_per_step,
        "simulate_rmse": rmse_ns_per_step,
        "simulate (stores X, e, e)": simulate_ns_per_step,
    }
    times: dict[str, list[float]] = {name: [] for name in rows}
    for _ in range(repeats):  # interleaved, so that a burst of load hits every variant alike
        for name, fn in rows.items():
            times[name].append(fn(steps))
    print(
        f"(a) m = 3, truth + KBF + ISL, noise included, {steps:,} steps, {repeats} repeats "
        f"(load average {os.getloadavg()[0]:.2f}):"
    )
    for name, ts in times.items():
        print(f"    {name:28s} median {statistics.median(ts):7.1f} ns/step   best {min(ts):7.1f}")
    n_ref = 2000
    ref = reference_ns_per_step(n_ref)
    print(
        f"    {'numpy reference':28s} {ref:9.0f} ns/step on {n_ref:,} steps "
        f"({ref / statistics.median(times['kernel (advance)']):,.0f}× the kernel)"
    )


_FRESH = r"""
import json, time
t0 = time.perf_counter()
import isl_core
from isl_core import Model, simulate
from isl_core.kernels import advance
t1 = time.perf_counter()
run = simulate(Model(0.5, 3.0, 20.0, 3), 3.0, seed=1)
t2 = time.perf_counter()
sigs, misses = len(advance.signatures), sum(advance.stats.cache_misses.values())
run = simulate(Model(0.5, 3.0, 200.0, 3), 3.0, seed=2)
t3 = time.perf_counter()
print(json.dumps(dict(imp=t1 - t0, first=t2 - t1, second=t3 - t2, N=run.N, sigs=sigs,
                      sigs_after=len(advance.signatures), hits=sum(advance.stats.cache_hits.values()),
                      misses=misses, misses_after=sum(advance.stats.cache_misses.values()))))
"""


def part_b() -> None:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (os.getcwd(), os.environ.get("PYTHONPATH")) if p))
    cmd = [sys.executable, "-c", _FRESH]
    subprocess.run(cmd, check=True, capture_output=True, env=env)  # make sure the numba cache exists
    walls, infos = [], []
    for _ in range(3):
        t0 = time.perf_counter()
        out = subprocess.run(cmd, check=True, capture_output=True, text=True, env=env)
        walls.append(time.perf_counter() - t0)
        infos.append(json.loads(out.stdout.strip().splitlines()[-1]))
    i = infos[int(np.argsort(walls)[1])]  # the median run
    print(
        f"(b) fresh process: import isl_core + Fig. 3 (σ = 20, N = {i['N']:,}) — wall time median "
        f"{statistics.median(walls):.2f} s (runs: {', '.join(f'{w:.2f}' for w in walls)} s)"
    )
    print(
        f"    inside: import {i['imp']:.2f} s, first simulate {i['first'] * 1e3:.0f} ms, "
        f"second simulate (σ = 200) {i['second'] * 1e3:.0f} ms"
    )
    print(
        f"    numba: kernel signatures {i['sigs']} → {i['sigs_after']} after the second call; cache hits "
        f"{i['hits']}, cache misses (= compilations) {i['misses']} → {i['misses_after']}"
    )


def part_c(steps: int) -> None:
    _, h = _setup()
    simulate(FIG3, NU, T=100 * h, h=h)  # warm
    tracemalloc.start()
    run = simulate(FIG3, NU, T=steps * h, h=h, seed=1)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    arrays = {
        id(a.base if a.base is not None else a): (a.base if a.base is not None else a)
        for a in (run.t, run.X, *(tr.error for tr in run.tracks))
    }
    returned = sum(a.nbytes for a in arrays.values())
    print(
        f"(c) simulate over {run.N:,} steps (truth and each filter's error stored): "
        f"returned arrays {returned / 2**20:.1f} MiB, traced peak "
        f"{peak / 2**20:.1f} MiB → peak/returned = {peak / returned:.2f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1_000_000)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    part_a(args.steps, args.repeats)
    part_b()
    part_c(args.steps)


if __name__ == "__main__":
    main()
