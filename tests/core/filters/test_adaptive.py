"""The adaptive Kalman–Bucy filter (σ estimated online): its gain table, its σ̂, and its ratio near the optimum.

Statistics: ratios come with batch-means Student intervals (:func:`isl_core.sweep.ratio_interval`) at LEVEL."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from isl_core import FilterSpec, Model, kalman_bucy, optimal_kbf, simulate, simulate_rmse
from isl_core.filters.adaptive import MEMORY, TABLE_MARGIN, TABLE_PER_DECADE, adaptive_kbf, gain_table, sigma_hat_sd
from isl_core.sweep import ratio_interval
from isl_core.theory import predicted_covariance

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


def test_gain_table_is_the_care_gain_and_exact_between_points_for_alpha0():
    for model in (FIG3, Model(0.0, 3.0, 5.0, 3), Model.from_w(25.0, 3.0, 2.0, 4)):
        sig = np.geomspace(0.05, 5e3, 7)
        expected = np.array([kalman_bucy(Model(model.alpha, model.beta, s, model.m)).K for s in sig])
        np.testing.assert_allclose(gain_table(model, sig), expected, rtol=1e-9)
    spec = adaptive_kbf(Model(0.0, 3.0, 5.0, 3), sigma_range=(2.0, 200.0))
    table = spec.adaptive
    decades = math.log10(200.0 * TABLE_MARGIN / (2.0 / TABLE_MARGIN))
    assert len(table.log_gain) == round(TABLE_PER_DECADE * decades) + 1 and table.memory == MEMORY
    assert table.sigmas[0] == pytest.approx(2.0 / TABLE_MARGIN) and table.sigma_init == pytest.approx(20.0)
    for s in (0.37, 3.3, 47.0, 555.0):  # α = 0: K_i = G_i1 (β/σ)^{i/m} (B.18), linear in log–log
        np.testing.assert_allclose(table.gain(s), kalman_bucy(Model(0.0, 3.0, s, 3)).K, rtol=1e-12)
    np.testing.assert_allclose(table.gain(1e-9), np.exp(table.log_gain[0]), rtol=1e-15)  # held at the ends
    np.testing.assert_allclose(spec.coef, table.gain(20.0), rtol=1e-15)


def test_adaptive_run_exposes_sigma_hat():
    window = 200
    spec = adaptive_kbf(FIG3, sigma_range=(2.0, 200.0), memory=window)
    run = simulate(FIG3, 3.0, seed=1, extra=[spec], T=1500.0 / kalman_bucy(FIG3).r_min)
    sig = run.track("kbf_adaptive").sigma_hat
    assert sig.shape == run.t.shape and sig[0] == spec.adaptive.sigma_init and not sig.flags.writeable
    assert run.track("kbf").sigma_hat is None and run.track("isl").sigma_hat is None
    tail = sig[run.N // 10 :] / FIG3.sigma  # steady state: scatter as documented, 1/√(2(2W − 1))
    n_windows = len(tail) / (2 * window)  # ≈ independent stretches: rel. SE of an SD from n values ≈ 1/√(2n)
    assert n_windows >= 300
    assert abs(tail.std() / sigma_hat_sd(window) - 1.0) <= 3.0 / math.sqrt(2.0 * n_windows)
    res = simulate_rmse(FIG3, [optimal_kbf(FIG3, kalman_bucy(FIG3)), spec], T=50.0, batches=4)
    assert np.all(np.isnan(res.sigma_hat[:, 0])) and np.all(np.isfinite(res.sigma_hat[:, 1]))
    assert np.isnan(res.sigma_hat_final[0]) and res.sigma_hat_final[1] > 0


@pytest.mark.parametrize("alpha, sigma", [(0.5, 20.0), (0.04, 200.0), (25.0, 2.0)])
def test_adaptive_kbf_learns_sigma_and_reaches_the_optimum(alpha, sigma):
    """σ̂ → σ and the RMSE ratio → 1 (paired with the oracle on the same noise).

    * time average of σ̂ after the burn-in: within 4 batch-means SE of σ, plus 0.1 % for the O((h·rate)²)
      remainder of Mehra's correction (it uses the continuous Δ_11 for the grid's E e_1²);
    * final σ̂: a single draw of the EWMA, within 5 of its documented SDs 1/√(2(2W − 1));
    * ratios: the adaptive filter within 1 % of the oracle on the same noise (its cost is second order in the
      ≈ 1.6 % scatter of σ̂), and both cover the oracle's exact Euler-grid value within the interval.
    """
    model = Model.from_w(alpha, 3.0, sigma, 3)
    oracle = optimal_kbf(model, kalman_bucy(model))
    spec = adaptive_kbf(model, sigma_range=(2.0, 200.0))
    res, ratio, low, high = _long_run(model, [oracle, spec], horizon=1000.0, seed=5)
    per_batch = res.sigma_hat[:, 1] / sigma
    se = per_batch.std(ddof=1) / math.sqrt(BATCHES)
    assert abs(per_batch @ res.counts / res.counts.sum() - 1.0) <= 4.0 * se + 1e-3, (per_batch, se)
    assert se <= 3.0 / math.sqrt(2.0 * res.counts.sum())  # the batches agree with the documented σ/√(2L)
    assert abs(res.sigma_hat_final[1] / sigma - 1.0) <= 5.0 * sigma_hat_sd(MEMORY)
    assert np.all(np.abs(ratio[1] - ratio[0]) <= 0.01), ratio
    grid = _grid_ratio(model, oracle, res.h)
    assert np.all((low <= grid) & (grid <= high)), (low, high, grid)


def test_adaptive_filter_rides_on_the_same_noise():
    """Adding the adaptive filter changes nothing else in the run (common random numbers, same h)."""
    kb = kalman_bucy(FIG3)
    T, h = 30.0 / kb.r_min, 0.002
    plain = simulate(FIG3, 3.0, T=T, h=h, seed=2)
    more = simulate(FIG3, 3.0, T=T, h=h, seed=2, extra=[adaptive_kbf(FIG3)])
    np.testing.assert_array_equal(plain.X, more.X)
    np.testing.assert_array_equal(plain.X_check, more.X_check)


def test_bad_adaptive_table_is_rejected():
    spec = adaptive_kbf(FIG3)
    bad = dataclasses.replace(spec, adaptive=dataclasses.replace(spec.adaptive, log_gain=np.zeros((1, 3))))
    with pytest.raises(ValueError, match=r"adaptive gain table of shape \(n >= 2, m\)"):
        simulate(FIG3, 3.0, extra=[bad])
