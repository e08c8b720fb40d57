"""The Kalman–Bucy filters designed for a guessed σ̄ (mismatched, minimax): the optimal one at σ̄ = σ, and their
stationary error, the exact Lyapunov solution on the simulated grid (:ref:`mismatched-kbf`)."""

from __future__ import annotations

import numpy as np
import pytest

from isl_core import FilterSpec, Model, kalman_bucy, simulate, simulate_rmse
from isl_core.filters.baselines import baseline_filters
from isl_core.filters.kalman import mismatched_kbf
from isl_core.grid import H_RATE
from isl_core.sweep import ratio_interval
from isl_core.theory import predicted_covariance, theory_ratios

LEVEL = 0.99
BATCHES = 20
FIG3 = Model.from_w(0.5, 3.0, 20.0, 3)


def _long_run(model: Model, specs, *, horizon: float, seed: int):
    """``simulate_rmse`` over ``horizon``/r_min after 10/r_min, and its ratios with a LEVEL interval (nf, m)."""
    r_min = kalman_bucy(model).r_min
    res = simulate_rmse(model, specs, T=(10.0 + horizon) / r_min, burn=10.0 / r_min, batches=BATCHES, seed=seed)
    return res, *ratio_interval(res.sq, res.counts, res.s, LEVEL)


def _grid_ratio(model: Model, spec: FilterSpec, h: float) -> np.ndarray:
    """Exact stationary RMSE ratio of a linear filter on the Euler grid of step h."""
    return np.sqrt(np.diagonal(predicted_covariance(model, spec, h=h))) / kalman_bucy(model).s


def test_mismatched_with_the_true_sigma_is_the_optimal_filter_bit_for_bit():
    (same,) = baseline_filters(FIG3, nu=3.0, sigma_design=FIG3.sigma, names=("kbf_mismatched",))
    run = simulate(FIG3, 3.0, seed=3, extra=[same])
    np.testing.assert_array_equal(run.track("kbf_mismatched").estimate, run.X_hat)
    np.testing.assert_allclose(theory_ratios(FIG3, same), 1.0, rtol=1e-9)


@pytest.mark.parametrize("alpha, sigma, design", [(0.5, 20.0, 2.0), (0.5, 20.0, 200.0), (5.0, 2.0, 20.0)])
def test_mismatched_kbf_matches_its_lyapunov_prediction(alpha, sigma, design):
    """Simulated ratios cover the exact Euler-grid value; that value is the Lyapunov one + O(h·rate)."""
    model = Model.from_w(alpha, 3.0, sigma, 3)
    spec = mismatched_kbf(model, design)
    res, ratio, low, high = _long_run(model, [spec], horizon=1000.0, seed=17)
    grid = _grid_ratio(model, spec, res.h)
    continuous = theory_ratios(model, spec)
    assert np.all((low[0] <= grid) & (grid <= high[0])), (ratio[0], low[0], high[0], grid)
    assert np.all(np.abs(grid / continuous - 1.0) <= 2 * H_RATE), (grid, continuous)
