"""Where a truth exists: a run of the dashboard downloaded as CSV (Trajectories) and read back as a recorded series
gives the simulation's Kalman–Bucy estimates again (:ref:`data-readings`).

The CSV's ``reading`` column holds each interval's average of the observation, which the simulation's filter took in;
read back with :func:`isl_core.series.read_csv` and run through the simulation's Euler step
(:func:`isl_core.series.euler.euler_kalman_bucy`) from the CSV's first estimate, it must give the run's X̂ up to what
the file's 9 significant digits lose: each written number is off by at most 5·10⁻⁹ of itself, and the recursion
X̂_k = M·X̂_{k−1} + h·K·z_k carries an error δz of the readings into X̂_i by at most Σ_j |(M^j h K)_i|·max|δz| (and
one of the start by max_k Σ_l |(M^k)_il|·|δX̂_l(0)|) — the bound the test computes for the run.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from app import pipeline
from app.state import AppState
from isl_core import Model, kalman_bucy, simulate
from isl_core.series import read_csv
from isl_core.series.euler import euler_kalman_bucy

pytest.importorskip("pandas", reason="the data extra: pip install 'isl[data]'")

DIGITS = 5e-9  #: the relative error of a number written with 9 significant digits (%.9g): half a unit of the last


def _bound(model: Model, h: float, n: int, z_max: float, start_max: float) -> np.ndarray:
    """The most the CSV's rounding can move each coordinate of X̂ (module docstring)."""
    K = np.asarray(kalman_bucy(model).K)
    M = np.eye(model.m) + h * np.asarray(model.A)
    M[:, 0] -= h * K
    gain, power, start = np.zeros(model.m), np.eye(model.m), np.zeros(model.m)
    for _ in range(n):
        gain += np.abs(power @ (h * K))
        start = np.maximum(start, np.abs(power).sum(axis=1))
        power = M @ power
    return DIGITS * (gain * z_max + start * start_max)


@pytest.mark.parametrize(
    "inputs", [{}, {"m": 2, "alpha": 2.0, "sigma": 5.0, "seed": 5, "horizon": 5.0}], ids=["fig3", "m2"]
)
def test_a_downloaded_run_read_back_gives_the_simulations_estimates(inputs):
    state = AppState(**inputs)
    state.start()
    text = state.csv().getvalue()
    h = float(re.search(r" h=(\S+) ", text).group(1))
    s = read_csv(text.encode(), time="t", value="reading", name="run.csv")
    req = state.shown_request
    model = Model(req.alpha, req.beta, req.sigma, req.m)
    extra, grid = pipeline.extra_filters(req, model)  # the grid the page's run is on (as the download's)
    run = simulate(model, req.nu, horizon=req.horizon, seed=req.seed, extra=extra, step_filters=grid)
    assert s.n == run.N + 1 and np.isnan(s.z[0]) and s.present[1:].all()
    first = next(line for line in text.splitlines() if not line.startswith("#"))
    written = np.array(first.split(","), dtype=float)
    start = written[2 + req.m : 2 + 2 * req.m]  # the CSV's kbf estimates at t = 0
    got = euler_kalman_bucy(s, model, start, h=h)
    tol = _bound(model, h, run.N, float(np.nanmax(np.abs(s.z))), float(np.max(np.abs(start))))
    tol += 1e-12 * np.max(np.abs(run.X_hat), axis=0)  # the two recursions' own float rounding, far below
    err = np.max(np.abs(got - run.X_hat), axis=0)
    assert np.all(err <= tol), (err, tol)
    # and not by luck: the readings of another seed give another X̂, far outside the bound
    other = simulate(model, req.nu, horizon=req.horizon, seed=req.seed + 1, step_filters=grid, readings=True)
    moved = euler_kalman_bucy(s.__class__(s.t, other.readings, s.name), model, start, h=h)
    assert np.all(np.max(np.abs(moved - run.X_hat), axis=0) > 100 * tol)
