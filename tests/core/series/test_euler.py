"""The readings a simulation's filters took in (``simulate(readings=True)``) and the simulation's Euler-grid
Kalman–Bucy filter over them (:func:`isl_core.series.euler.euler_kalman_bucy`): the same X̂ as the run, bit for bit
up to rounding, at every step and at every k-th step."""

from __future__ import annotations

import numpy as np
import pytest

from isl_core import Model, simulate
from isl_core.series import series
from isl_core.series.euler import euler_kalman_bucy


@pytest.fixture(scope="module")
def model():
    return Model.from_w(0.5, 3.0, 20.0, 3)


def test_the_readings_replay_the_filters_noise(model):
    run = simulate(model, nu=model.beta, horizon=3.0, seed=4, readings=True)
    assert np.isnan(run.readings[0]) and np.all(np.isfinite(run.readings[1:]))
    got = euler_kalman_bucy(series(run.t, run.readings), model, run.X_hat[0])
    scale = np.max(np.abs(run.X_hat), axis=0)
    assert np.all(np.max(np.abs(got - run.X_hat), axis=0) <= 1e-11 * scale)  # two orders of the same sums
    # every k-th step: each reading the average over its k steps, the same observation
    coarse = simulate(model, nu=model.beta, horizon=3.0, seed=4, readings=True, every=5)
    k = len(coarse.readings) - 1
    means = run.readings[1 : 5 * k + 1].reshape(k, 5).mean(axis=1)
    np.testing.assert_allclose(coarse.readings[1:], means, rtol=1e-10, atol=1e-12 * np.max(np.abs(means)))
    assert simulate(model, nu=model.beta, horizon=3.0, seed=4).readings is None  # not unless asked for


def test_refusals_name_what_is_wrong(model):
    t = np.arange(12.0)
    with pytest.raises(ValueError, match="start must hold the m = 3 coordinates"):
        euler_kalman_bucy(series(t, t), model, [0.0])
    with pytest.raises(ValueError, match="regular times"):
        euler_kalman_bucy(series(np.r_[t, 12.5], np.r_[t, 1.0]), model, np.zeros(3))
    with pytest.raises(ValueError, match="row 4 has none"):
        euler_kalman_bucy(series(t, np.where(t == 3, np.nan, t)), model, np.zeros(3))
    with pytest.raises(ValueError, match="not the grid"):
        euler_kalman_bucy(series(t, t), model, np.zeros(3), h=0.5)
