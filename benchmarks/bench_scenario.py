"""Cost of a scenario run against today's run of the same length (issue: ≤ 1.5×).

    PYTHONPATH=. python benchmarks/bench_scenario.py [--steps 1000000] [--repeats 5]

"Today's run" is :func:`isl_core.simulate_rmse` of the Kalman–Bucy and ISL filters (squared errors only, no
trajectories) on paper A's Fig. 3 model; a scenario run is :func:`isl_core.scenario_run.simulate_scenario` with the
same two filters plus the clairvoyant one it always carries, over the same number of steps, for the constant
Gaussian scenario, a σ step 20 → 2, Student-t noise (d = 3), 1 % outliers × 30 and a sensor read every 0.1/r_min.
Its time includes the clairvoyant Riccati recursion over every step. Printed: median ns/step of ``--repeats``
interleaved runs and the ratio to today's. Timings on a shared machine are noisy: read the load average.
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

from isl_core import Model, isl_filter, kalman_bucy, optimal_kbf, simulate_rmse
from isl_core.scenario import Scenario
from isl_core.scenario_run import simulate_scenario

FIG3 = Model(0.5, 3.0, 20.0, 3)
NU = 3.0
SCENARIOS = {
    "constant σ, Gaussian": Scenario(),
    "σ 20 → 2 at 10/r_min": Scenario(sigma_knots=((10.0, 2.0),)),
    "Student-t, d = 3": Scenario(noise="student", dof=3.0),
    "1 % outliers × 30": Scenario(noise="outliers"),
    "sensor every 0.1/r_min": Scenario(sensor_interval=0.1),
}


def today(n_target: int) -> tuple[float, int, float]:
    """ns/step of today's run, its step count and its horizon (1/r_min) for about ``n_target`` steps."""
    kb = kalman_bucy(FIG3)
    probe = simulate_scenario(FIG3, NU, Scenario(), horizon=10.0, windows=1)
    horizon = 10.0 * n_target / probe.N
    run = simulate_scenario(FIG3, NU, Scenario(), horizon=horizon, windows=1)
    specs = [optimal_kbf(FIG3, kb), isl_filter(FIG3, NU)]
    t0 = time.perf_counter()
    simulate_rmse(FIG3, specs, T=run.N * run.h, h=run.h, seed=1)
    return (time.perf_counter() - t0) / run.N * 1e9, run.N, horizon


def scenario_ns(scenario: Scenario, horizon: float) -> tuple[float, int]:
    t0 = time.perf_counter()
    run = simulate_scenario(FIG3, NU, scenario, horizon=horizon, windows=50, seed=1)
    return (time.perf_counter() - t0) / run.N * 1e9, run.N


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--steps", type=int, default=1_000_000)
    p.add_argument("--repeats", type=int, default=5)
    opts = p.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f} (2 cores)")
    today(10_000)  # compile or load every kernel from the cache
    for sc in SCENARIOS.values():
        scenario_ns(sc, 1.0)
    base, times = [], {name: [] for name in SCENARIOS}
    steps = {}
    for _ in range(opts.repeats):
        ns, n, horizon = today(opts.steps)
        base.append(ns)
        for name, sc in SCENARIOS.items():
            ns, steps[name] = scenario_ns(sc, horizon)
            times[name].append(ns)
    ref = statistics.median(base)
    print(f"today's run (simulate_rmse, KBF + ISL), {n:,} steps: {ref:7.1f} ns/step")
    for name, ts in times.items():
        med = statistics.median(ts)
        print(f"  scenario {name:26s} {steps[name]:>10,} steps: {med:7.1f} ns/step  ({med / ref:4.2f}× today's)")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
