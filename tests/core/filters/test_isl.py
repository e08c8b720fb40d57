"""The ISL filters: the model-aware one is paper A's at α = 0, and its theory matches simulation near its best ν.

Statistics: ratios come with batch-means Student intervals (:func:`isl_core.sweep.ratio_interval`) at LEVEL."""

from __future__ import annotations

import numpy as np
import pytest

from isl_core import Model, isl_filter, kalman_bucy, simulate, simulate_rmse
from isl_core.filters.isl import model_aware_isl
from isl_core.sweep import ratio_interval
from isl_core.theory import predicted_ratios_grid, theory_ratios

LEVEL = 0.99
BATCHES = 20


def _long_run(model: Model, specs, *, horizon: float, seed: int):
    """``simulate_rmse`` over ``horizon``/r_min after 10/r_min, and its ratios with a LEVEL interval (nf, m)."""
    r_min = kalman_bucy(model).r_min
    res = simulate_rmse(model, specs, T=(10.0 + horizon) / r_min, burn=10.0 / r_min, batches=BATCHES, seed=seed)
    return res, *ratio_interval(res.sq, res.counts, res.s, LEVEL)


def test_model_aware_isl_at_alpha0_is_the_paper_filter_bit_for_bit():
    model = Model(0.0, 3.0, 5.0, 3)
    aware = model_aware_isl(model, 2.0)
    assert aware.damp == 0.0 and aware.name == "isl_model"
    run = simulate(model, 2.0, seed=4, extra=[aware])
    np.testing.assert_array_equal(run.track("isl_model").estimate, run.X_check)
    np.testing.assert_array_equal(theory_ratios(model, aware), theory_ratios(model, isl_filter(model, 2.0)))


@pytest.mark.parametrize("alpha, sigma", [(1.0, 20.0), (5.0, 2.0), (0.2, 200.0)])
def test_model_aware_isl_theory_matches_simulation_near_its_best_nu(alpha, sigma):
    """:ref:`linearized-covariance` with A in place of A0 (no X_m coupling): within the interval + 5 % at the predicted
    best ν."""
    model = Model.from_w(alpha, 3.0, sigma, 3)
    nus = model.beta * 2.0 ** np.arange(-9.0, 3.0, 0.25)
    pred = predicted_ratios_grid(model, nus, damp=alpha)
    k = int(np.argmin(pred.max(axis=1)))
    spec = model_aware_isl(model, nus[k])
    _, ratio, low, high = _long_run(model, [spec], horizon=1000.0, seed=23)
    half = np.maximum(ratio[0] - low[0], high[0] - ratio[0])
    assert np.all(np.abs(ratio[0] - pred[k]) <= half + 0.05 * pred[k]), (ratio[0], pred[k], half)
