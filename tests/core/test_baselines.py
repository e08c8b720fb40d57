"""The baselines of a user without σ: mismatched, minimax and adaptive Kalman–Bucy filters, model-aware ISL.

Statistics: ratios come with batch-means Student intervals (:func:`isl_core.sweep.ratio_interval`) at LEVEL.
Fixed-gain filters are linear, so the stationary covariance of their Euler recursion
(``predicted_covariance(..., h=run.h)``) is *exact* for the simulated scheme: simulation must cover it.
It differs from the continuous Lyapunov answer (the SPEC's theory) by O(h·rate), checked separately.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from isl_core import FilterSpec, Model, isl_filter, kalman_bucy, optimal_kbf, simulate, simulate_rmse
from isl_core.adaptive import TABLE_MARGIN, TABLE_PER_DECADE, MEMORY, adaptive_kbf, gain_table, sigma_hat_sd
from isl_core.baselines import (
    BASELINES,
    LABELS,
    baseline_filters,
    design_sigma,
    minimax_kbf,
    model_aware_isl,
    theory_ratios,
)
from isl_core.filters import KIND_ADAPTIVE, KIND_LINEAR, KIND_POWER
from isl_core.grid import H_RATE
from isl_core.sweep import ratio_interval
from isl_core.theory import mismatched_kbf, mismatched_kbf_ratios, predicted_covariance, predicted_ratios_grid

EPS = np.finfo(float).eps
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


# -------------------------------------------------------------------------------------------- the registry

def test_registry_names_kinds_and_defaults():
    specs = baseline_filters(FIG3, nu=3.0, sigma_range=(2.0, 200.0))
    assert tuple(s.name for s in specs) == BASELINES and set(LABELS) == set(BASELINES)
    by = {s.name: s for s in specs}
    assert [by[n].kind for n in BASELINES] == [KIND_LINEAR, KIND_POWER, KIND_LINEAR, KIND_LINEAR, KIND_ADAPTIVE,
                                               KIND_POWER]
    assert [by[n].damp for n in BASELINES] == [FIG3.alpha, 0.0, FIG3.alpha, FIG3.alpha, FIG3.alpha, FIG3.alpha]
    assert design_sigma((2.0, 200.0)) == pytest.approx(20.0, rel=4 * EPS)  # the geometric middle
    np.testing.assert_array_equal(by["kbf_mismatched"].coef, mismatched_kbf(FIG3, design_sigma((2.0, 200.0))).coef)
    np.testing.assert_array_equal(by["kbf_minimax"].coef, mismatched_kbf(FIG3, 200.0).coef)
    np.testing.assert_array_equal(by["isl_model"].coef, by["isl"].coef)  # same φ, only the propagation differs
    np.testing.assert_array_equal(by["kbf"].coef, kalman_bucy(FIG3).K)
    picked = baseline_filters(FIG3, nu=3.0, nu_model=1.5, sigma_design=7.0, names=("isl_model", "kbf_mismatched"))
    assert [s.name for s in picked] == ["isl_model", "kbf_mismatched"]
    np.testing.assert_array_equal(picked[0].coef, isl_filter(FIG3, 1.5).coef)
    np.testing.assert_array_equal(picked[1].coef, mismatched_kbf(FIG3, 7.0).coef)
    np.testing.assert_array_equal(minimax_kbf(FIG3, (1.0, 50.0)).coef, mismatched_kbf(FIG3, 50.0).coef)


@pytest.mark.parametrize("kwargs, pattern", [
    ({"names": ("kbf", "nope")}, r"^names must be a non-empty sequence of distinct names from"),
    ({"names": ("kbf", "kbf")}, r"^names must be"),
    ({"names": ()}, r"^names must be"),
    ({"names": "kbf"}, r"^names must be"),
    ({"sigma_range": (5.0, 2.0)}, r"^sigma_range\[1\] must be a finite number >= 5"),
    ({"sigma_range": 3.0}, r"^sigma_range must be a pair"),
    ({"sigma_range": (0.0, 2.0)}, r"^sigma_range\[0\] must be a finite number > 0"),
    ({"memory": 0.5}, r"^memory \(W, in sensor readings\) must be a finite number >= 1"),
    ({"sigma_design": math.nan, "names": ("kbf_mismatched",)}, r"^sigma_design must be a finite number > 0"),
    ({"nu": -1.0, "names": ("isl",)}, r"^nu must be a finite number > 0"),
])
def test_registry_rejects_bad_input(kwargs, pattern):
    kwargs = {"nu": 3.0, **kwargs}
    with pytest.raises(ValueError, match=pattern):
        baseline_filters(FIG3, **kwargs)


def test_theory_per_filter():
    """Fixed gains: the mismatched-gain Lyapunov equation (SPEC §7); oracle 1; adaptive: no theory (nan)."""
    specs = {s.name: s for s in baseline_filters(FIG3, nu=3.0, sigma_design=5.0)}
    np.testing.assert_allclose(theory_ratios(FIG3, specs["kbf"]), 1.0, rtol=1e-9)
    np.testing.assert_allclose(theory_ratios(FIG3, specs["kbf_mismatched"]), mismatched_kbf_ratios(FIG3, 5.0),
                               rtol=1e-12)
    np.testing.assert_allclose(theory_ratios(FIG3, specs["isl_model"]),
                               predicted_ratios_grid(FIG3, [3.0], damp=FIG3.alpha)[0], rtol=1e-12)
    assert np.all(np.isnan(theory_ratios(FIG3, specs["kbf_adaptive"])))


# ------------------------------------------------------------------------------------ mismatched / minimax

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


# ------------------------------------------------------------------------------------------- adaptive KBF

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
    tail = sig[run.N // 10:] / FIG3.sigma  # steady state: scatter as documented, 1/√(2(2W − 1))
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


# ------------------------------------------------------------------------------------- model-aware ISL

def test_model_aware_isl_at_alpha0_is_the_paper_filter_bit_for_bit():
    model = Model(0.0, 3.0, 5.0, 3)
    aware = model_aware_isl(model, 2.0)
    assert aware.damp == 0.0 and aware.name == "isl_model"
    run = simulate(model, 2.0, seed=4, extra=[aware])
    np.testing.assert_array_equal(run.track("isl_model").estimate, run.X_check)
    np.testing.assert_array_equal(theory_ratios(model, aware), theory_ratios(model, isl_filter(model, 2.0)))


@pytest.mark.parametrize("alpha, sigma", [(1.0, 20.0), (5.0, 2.0), (0.2, 200.0)])
def test_model_aware_isl_theory_matches_simulation_near_its_best_nu(alpha, sigma):
    """SPEC §6 with A in place of A0 (no X_m coupling): within the interval + 5 % at the predicted best ν."""
    model = Model.from_w(alpha, 3.0, sigma, 3)
    nus = model.beta * 2.0 ** np.arange(-9.0, 3.0, 0.25)
    pred = predicted_ratios_grid(model, nus, damp=alpha)
    k = int(np.argmin(pred.max(axis=1)))
    spec = model_aware_isl(model, nus[k])
    _, ratio, low, high = _long_run(model, [spec], horizon=1000.0, seed=23)
    half = np.maximum(ratio[0] - low[0], high[0] - ratio[0])
    assert np.all(np.abs(ratio[0] - pred[k]) <= half + 0.05 * pred[k]), (ratio[0], pred[k], half)


def test_euler_grid_covariance_is_the_discrete_lyapunov_solution():
    """``predicted_covariance(h=...)``: P = F P Fᵀ + h·Q for the error recursion of a linear filter on the grid."""
    from scipy.linalg import solve_discrete_lyapunov

    spec = mismatched_kbf(FIG3, 3.0)
    h = 0.01
    F = np.eye(3) + h * (FIG3.A - np.outer(spec.coef, FIG3.C[0]))  # e ← (I + h(A − K̄C))e + K̄σ√h ε − βE√h v
    Q = h * (FIG3.beta**2 * (FIG3.E @ FIG3.E.T) + FIG3.sigma**2 * np.outer(spec.coef, spec.coef))
    np.testing.assert_allclose(predicted_covariance(FIG3, spec, h=h), solve_discrete_lyapunov(F, Q), rtol=1e-10)
    with pytest.raises(ValueError, match=r"^h must be a finite number > 0"):
        predicted_covariance(FIG3, spec, h=0.0)
