"""Statistical-linearization theory (B.40–B.52, :ref:`theory`, :ref:`mismatched-kbf`): closed forms, residuals, and
simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _reference import care, worst_fixed_gain
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import solve_continuous_lyapunov
from scipy.stats import t as student_t

from isl_core import (
    FilterSpec,
    Model,
    isl_filter,
    kalman_bucy,
    linearization,
    linearized_matrix,
    optimal_kbf,
    simulate_rmse,
)
from isl_core.filters.kalman import mismatched_kbf
from isl_core.theory import (
    lyapunov,
    mismatched_kbf_ratios,
    predicted_covariance,
    predicted_ratios,
    predicted_ratios_grid,
)

EPS = np.finfo(float).eps
BATCHES = 20
LEVEL = 0.95  # two-sided confidence level of the batch-means intervals
FIG3 = Model.from_w(0.5, 3.0, 20.0, 3)  # paper A, Fig. 3 (σ = 20)


def test_b52_white_noise_m1():
    """(B.52): m = 1, α = 0, ν = β → Δ̌/Q = √(π/2), so š/s = (π/2)^(1/4), for any β, σ."""
    for beta, sigma in [(1.0, 1.0), (3.0, 5.0), (0.2, 700.0)]:
        ratio = predicted_ratios(Model(0.0, beta, sigma, 1), beta)
        assert ratio.shape == (1,)
        assert abs(ratio[0] - (math.pi / 2) ** 0.25) < 1e-10


def test_m1_closed_form_any_nu():
    """m = 1, α = 0: Λ = −ν√(2/π)/σ and Φ = ν², so Δ̌ = σ(β² + ν²)√(π/2)/(2ν) against Q = σβ (B.48)."""
    beta, sigma = 2.0, 7.0
    for nu in [0.1, 1.0, 2.0, 30.0]:
        expected = math.sqrt(sigma * (beta**2 + nu**2) * math.sqrt(math.pi / 2) / (2 * nu) / (sigma * beta))
        assert predicted_ratios(Model(0.0, beta, sigma, 1), nu)[0] == pytest.approx(expected, rel=1e-12)


def test_lyapunov_matches_scipy():
    rng = np.random.default_rng(3)
    for n in range(1, 8):
        G = rng.standard_normal((n, n))
        M = G - (np.linalg.eigvals(G).real.max() + 0.5) * np.eye(n)
        assert np.all(np.linalg.eigvals(M).real < 0)
        B = rng.standard_normal((n, n))
        Q = B @ B.T
        P = lyapunov(M, Q)
        ref = solve_continuous_lyapunov(M, -Q)
        assert np.allclose(P, ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())
        assert np.abs(M @ P + P @ M.T + Q).max() <= 1e3 * EPS * np.abs(Q).max() * n


def test_b48_residual_alpha0():
    """α = 0, paper B's filter: the covariance solves ΛΔ̌ + Δ̌Λᵀ + β²EEᵀ + Φ = 0 (B.48)."""
    model = Model(0.0, 3.0, 5.0, 3)
    spec = isl_filter(model, 2.5)
    P = predicted_covariance(model, spec)
    lam = linearized_matrix(model, spec)
    _, Phi = linearization(spec.coef, spec.exponents(), model.sigma)
    res = lam @ P + P @ lam.T + model.beta**2 * (model.E @ model.E.T) + Phi
    assert np.abs(res).max() <= 1e4 * EPS * np.abs(Phi).max()
    assert np.all(np.linalg.eigvalsh(P) > 0)


@settings(max_examples=40)
@given(
    alpha=st.one_of(st.just(0.0), st.floats(1e-3, 50.0)),
    beta=st.floats(0.1, 50.0),
    sigma=st.floats(0.1, 1000.0),
    m=st.integers(1, 6),
)
def test_mismatched_kbf_with_true_sigma_is_optimal(alpha, beta, sigma, m):
    """σ̄ = σ: the mismatched-gain Lyapunov equation (:ref:`mismatched-kbf`) has the CARE solution Δ as its root."""
    model = Model(alpha, beta, sigma, m)
    kb = kalman_bucy(model)
    assert np.allclose(mismatched_kbf_ratios(model, sigma), 1.0, rtol=1e-7, atol=0)
    P = predicted_covariance(model, mismatched_kbf(model, sigma))
    assert np.allclose(P, kb.delta, rtol=1e-6, atol=1e-9 * np.abs(kb.delta).max())


def test_mismatched_kbf_residual_and_worse_than_optimal():
    """(A − K̄C)P + P(A − K̄C)ᵀ + β²EEᵀ + σ²K̄K̄ᵀ = 0, and P ≥ Δ (the optimal filter is optimal)."""
    model = Model.from_w(1.0, 3.0, 20.0, 3)
    kb = kalman_bucy(model)
    for sigma_design in [2.0, 200.0]:
        Kbar = mismatched_kbf(model, sigma_design).coef
        P = predicted_covariance(model, mismatched_kbf(model, sigma_design))
        closed = model.A - np.outer(Kbar, model.C[0])
        Q = model.beta**2 * (model.E @ model.E.T) + model.sigma**2 * np.outer(Kbar, Kbar)
        assert np.abs(closed @ P + P @ closed.T + Q).max() <= 1e4 * EPS * np.abs(Q).max()
        assert np.linalg.eigvalsh(P - kb.delta).min() > -1e-9 * np.abs(kb.delta).max()
        assert np.all(mismatched_kbf_ratios(model, sigma_design) > 1.0)


@pytest.mark.parametrize("alpha", [0.04, 1.0, 25.0])
def test_mismatched_kbf_worst_case_about_2_9(alpha):
    """:ref:`minimax-kbf`: the best fixed design σ̄ still loses ≈ 2.9× somewhere in σ ∈ [2, 200] (m = 3, w = 3).

    The minimax equals the one written out with scipy's CARE and Lyapunov solvers (tests/_reference.py) to rounding,
    and the paper's 2.9 to the digit it gives (±0.05)."""
    sigmas = np.geomspace(2.0, 200.0, 13)
    designs = np.geomspace(2.0, 200.0, 25)
    worst = min(max(mismatched_kbf_ratios(Model.from_w(alpha, 3.0, s, 3), d).max() for s in sigmas) for d in designs)
    assert worst == pytest.approx(worst_fixed_gain(alpha, 3.0, 3, sigmas, designs), rel=1e-9)
    assert abs(worst - 2.9) < 0.05, worst


def test_small_alpha_tends_to_white_noise_model():
    """The (e, X_m) system's coupling has variance α²·β²/(2α) → 0: α → 0 recovers (B.48)."""
    r0 = predicted_ratios(Model(0.0, 3.0, 20.0, 3), 3.0)
    r1 = predicted_ratios(Model(1e-9, 3.0, 20.0, 3), 3.0)
    assert np.allclose(r1, r0, rtol=1e-6)


def test_model_aware_isl_uncouples():
    """damp = α removes the (α − a)X_m coupling: the m×m equation (B.48) with Λ built on A."""
    model = Model.from_w(0.5, 3.0, 20.0, 3)
    spec = isl_filter(model, 3.0)
    aware = FilterSpec(spec.name, spec.label, model.alpha, spec.coef, True)
    lam = linearized_matrix(model, aware)
    _, Phi = linearization(spec.coef, spec.exponents(), model.sigma)
    ref = solve_continuous_lyapunov(lam, -(model.beta**2 * (model.E @ model.E.T) + Phi))
    assert np.allclose(predicted_covariance(model, aware), ref, rtol=1e-9)
    s = kalman_bucy(model).s
    assert np.allclose(predicted_ratios(model, 3.0, damp=model.alpha), np.sqrt(np.diag(ref)) / s, rtol=1e-9)


def test_grid_matches_pointwise():
    model = Model.from_w(5.0, 3.0, 200.0, 3)
    nus = model.beta * 2.0 ** np.arange(-8, 3)
    grid = predicted_ratios_grid(model, nus)
    assert grid.shape == (len(nus), 3)
    for row, nu in zip(grid, nus, strict=False):
        assert np.allclose(row, predicted_ratios(model, nu), rtol=1e-12)


def test_no_stationary_error_is_inf():
    model = Model.from_w(1.0, 3.0, 20.0, 3)
    kb = kalman_bucy(model)
    unstable = FilterSpec("bad", "negative gain", model.alpha, -np.array(kb.K), False)
    assert np.all(np.isinf(predicted_covariance(model, unstable)))
    assert np.all(np.isinf(predicted_ratios(Model(0.0, 3.0, 20.0, 3), 3.0, damp=0.5)))


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -1.0, 0.0, None, "3", True])
def test_bad_nu_names_the_parameter(bad):
    with pytest.raises(ValueError, match="nu"):
        predicted_ratios(Model(0.5, 3.0, 20.0, 3), bad)
    with pytest.raises(ValueError, match="sigma_design"):
        mismatched_kbf_ratios(Model(0.5, 3.0, 20.0, 3), bad if bad is not None else -2.0)


def _simulated(model: Model, filters, *, horizon: float, seed: int):
    """Whole-run ratios (nf, m), the half-width of their batch-means interval at level LEVEL, and the step h."""
    kb = kalman_bucy(model)
    res = simulate_rmse(model, filters, T=horizon / kb.r_min, burn=5.0 / kb.r_min, batches=BATCHES, seed=seed)
    batch = res.batch_ratios()
    half = student_t.ppf(0.5 + LEVEL / 2, BATCHES - 1) * batch.std(axis=0, ddof=1) / math.sqrt(BATCHES)
    return res.ratios(), half, res.h


def _optimal_on_the_grid(model: Model, h: float) -> np.ndarray:
    """√(P_ii/Δ_ii) of the optimal filter on the Euler grid of step h: e ← (I + h(A − KC))e + Kσ√h ε − βE√h v
    (B.30, B.33–B.34), P = F P Fᵀ + h(β²EEᵀ + σ²KKᵀ), K and Δ from scipy's CARE."""
    from scipy.linalg import solve_discrete_lyapunov

    delta = care(model.alpha, model.beta, model.sigma, model.m)
    K = delta[:, 0] / model.sigma**2
    F = np.eye(model.m) + h * (model.A - np.outer(K, model.C[0]))
    Q = h * (model.beta**2 * (model.E @ model.E.T) + model.sigma**2 * np.outer(K, K))
    return np.sqrt(np.diag(solve_discrete_lyapunov(F, Q)) / np.diag(delta))


def _assert_theory_matches(model: Model, nu: float, *, horizon: float = 1000.0, seed: int = 11) -> None:
    kb = kalman_bucy(model)
    filters = [optimal_kbf(model, kb), isl_filter(model, nu)]
    sim, half, h = _simulated(model, filters, horizon=horizon, seed=seed)
    grid_ratios = _optimal_on_the_grid(model, h)
    pred = predicted_ratios(model, nu)
    # the optimal filter sits at its Euler grid's exact ratio √(P_ii/Δ_ii) (P: the discrete Lyapunov equation of its
    # error recursion, :func:`isl_core.euler_bias`), within its batch-means interval
    assert np.all(np.abs(sim[0] - grid_ratios) <= half[0]), (sim[0], grid_ratios, half[0])
    assert np.all(np.abs(sim[1] - pred) <= half[1] + 0.05 * pred), (sim[1], pred, half[1])


@pytest.mark.parametrize("sigma", [20.0, 200.0])
def test_theory_matches_simulation_fig3(sigma):
    """Paper A, Fig. 3: m = 3, α = 0.5, ν = β = 3 (w = 3)."""
    _assert_theory_matches(Model.from_w(0.5, 3.0, sigma, 3), 3.0)


@pytest.mark.parametrize("alpha, sigma", [(0.04, 20.0), (1.0, 200.0), (25.0, 2.0)])
def test_theory_matches_simulation_fig2_best_nu(alpha, sigma):
    """Three cells of paper A's Fig. 2 at their best ν/β = 2^ℓ (best by the worst coordinate, in theory)."""
    model = Model.from_w(alpha, 3.0, sigma, 3)
    nus = model.beta * 2.0 ** np.arange(-8, 3)
    best = nus[np.argmin(predicted_ratios_grid(model, nus).max(axis=1))]
    _assert_theory_matches(model, best)


def test_linear_filter_on_a0_matches_simulation():
    """A Kalman–Bucy gain propagated with A0 (damp 0) on α > 0: the (α − a)X_m coupling alone, no φ approximation."""
    model = Model.from_w(0.5, 3.0, 20.0, 3)
    kb = kalman_bucy(model)
    spec = FilterSpec("kbf_a0", "K with A0", 0.0, np.array(kb.K), False)
    sim, half, _ = _simulated(model, [spec], horizon=1000.0, seed=5)
    pred = np.sqrt(np.diag(predicted_covariance(model, spec))) / kb.s
    assert np.all(pred > 1.0)
    assert np.all(np.abs(sim[0] - pred) <= half[0] + 0.02 * pred), (sim[0], pred, half[0])


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
