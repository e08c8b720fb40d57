"""Benchmark of recorded series (isl_core.series): the fit and every filter on 10⁵ and 10⁶ readings.

    PYTHONPATH=. python benchmarks/bench_data.py [--sizes 100000,1000000] [--m 2] [--repeats 3]

For each size N, a series drawn from the model (m = 2, α = 0.05, β = 0.02, σ_r = 1, Δ = 1, seed 0; 2 % of the readings
missing) is
(a) fitted at the given m (α free): wall time, and the number of log-likelihood evaluations it took;
(b) run through every filter (:data:`isl_core.series.SERIES_FILTERS`) at the true parameters: wall time of each,
    ns per reading, the best of ``--repeats`` (the numba kernels compiled before);
(c) both measured for peak memory (tracemalloc) against the bytes of the series.
Timings on a shared machine are noisy: read the load average printed with them.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import tracemalloc

import numpy as np

from isl_core.series import SERIES_FILTERS, ReadingModel, fit, run_filters, series
from isl_core.series.discretize import van_loan

TRUE = ReadingModel(2, 0.05, 0.02, 1.0)


def draw(n: int) -> object:
    """N readings of :data:`TRUE` every Δ = 1, 2 % missing (seed 0)."""
    F, Q = van_loan(TRUE.m, TRUE.alpha, TRUE.beta, np.array([1.0]))
    rng = np.random.default_rng(0)
    w = rng.standard_normal((n, TRUE.m)) @ np.linalg.cholesky(Q[0]).T
    x = np.zeros(TRUE.m)
    z = np.empty(n)
    f = F[0]
    for k in range(n):  # two coordinates written out: 10⁶ steps in about a second
        x = np.array([f[0, 0] * x[0] + f[0, 1] * x[1], f[1, 1] * x[1]]) + w[k]
        z[k] = x[0]
    z += TRUE.sigma_r * rng.standard_normal(n)
    z[rng.choice(n, n // 50, replace=False)] = np.nan
    return series(np.arange(float(n)), z, name="bench")


def _peak(fn):
    tracemalloc.start()
    t0 = time.perf_counter()
    out = fn()
    dt = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return out, dt, peak


def bench(n: int, m: int, repeats: int) -> dict:
    s = draw(n)
    calls = {"n": 0}
    mle = sys.modules["isl_core.series.mle"]  # the module (``isl_core.series.fit`` is the function)
    original = mle.loglik_at

    def counted(*a, **k):
        calls["n"] += 1
        return original(*a, **k)

    mle.loglik_at = counted
    try:
        f, t_fit, peak_fit = _peak(lambda: fit(s, m))
    finally:
        mle.loglik_at = original
    per = {}
    for name in SERIES_FILTERS:
        best = min(_peak(lambda name=name: run_filters(s, TRUE, names=[name]))[1] for _ in range(repeats))
        per[name] = {"seconds": best, "ns_per_reading": 1e9 * best / n}
    _, t_all, peak_all = _peak(lambda: run_filters(s, TRUE))
    return {
        "N": n,
        "fit_seconds": t_fit,
        "fit_loglik_calls": calls["n"],
        "fit_seconds_per_loglik": t_fit / max(1, calls["n"]),
        "fit_peak_MB": peak_fit / 1e6,
        "fitted": [f.params.alpha, f.params.beta, f.params.sigma_r],
        "filters": per,
        "all_filters_seconds": t_all,
        "all_filters_peak_MB": peak_all / 1e6,
        "series_MB": (s.t.nbytes + s.z.nbytes) / 1e6,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="100000,1000000")
    ap.add_argument("--m", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    run_filters(draw(200), TRUE)  # compile (or load) the kernels first
    fit(draw(200), args.m)
    out = {"load_average": os.getloadavg(), "results": []}
    for n in (int(x) for x in args.sizes.split(",")):
        out["results"].append(bench(n, args.m, args.repeats))
        print(json.dumps(out["results"][-1], indent=1), flush=True)
    print(json.dumps({"load_average_after": os.getloadavg()}))


if __name__ == "__main__":
    main()
