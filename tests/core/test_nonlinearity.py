"""The ISL nonlinearity φ (A.17), γ_p, and the closed-form statistical-linearization moments (B.40, B.43)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, stats

from isl_core import M_MAX, G_matrix, gamma_abs, isl_exponents, isl_gains, kalman_bucy_alpha0, linearization, phi

EPS = np.finfo(float).eps
QUAD_TOL = 1e-10  # relative accuracy asked of scipy's quad below


def gauss_expectation(fn, sigma: float) -> float:
    """E fn(ξ), ξ ~ N(0, σ²), by adaptive quadrature on each half line (independent of the closed forms)."""
    pdf = stats.norm(scale=sigma).pdf
    halves = [
        integrate.quad(lambda x: fn(x) * pdf(x), lo, hi, epsrel=QUAD_TOL, epsabs=0, limit=200)[0]
        for lo, hi in ((-np.inf, 0.0), (0.0, np.inf))
    ]
    return halves[0] + halves[1]


def test_gamma_small_integer_moments():
    # E|U|^0 = 1, E|U| = √(2/π), E U² = 1, E U⁴ = 3
    for p, expected in [(0.0, 1.0), (1.0, math.sqrt(2 / math.pi)), (2.0, 1.0), (4.0, 3.0)]:
        assert gamma_abs(p) == pytest.approx(expected, rel=8 * EPS)


def test_gamma_paper_b_values():
    # (B.54): γ_{4/3} ≈ 0.8309, γ_{2/3} ≈ 0.8024 — four printed digits
    assert f"{gamma_abs(4 / 3):.4f}" == "0.8309"
    assert f"{gamma_abs(2 / 3):.4f}" == "0.8024"


@pytest.mark.parametrize("p", [-0.5, 1 / 3, 2 / 3, 4 / 3, 5 / 3, 2.5])
def test_gamma_against_quadrature(p):
    assert gamma_abs(p) == pytest.approx(gauss_expectation(lambda x: abs(x) ** p, 1.0), rel=10 * QUAD_TOL)


def test_b27_coefficients_are_correlations_of_phi():
    # (B.27), m = 3: the correlation coefficients of φ(ξ) are γ_1/√(γ_{2/3}γ_{4/3}) ≈ 0.977,
    # γ_{2/3}/√γ_{4/3} ≈ 0.880, γ_{1/3}/√γ_{2/3} ≈ 0.957 — for every ν and σ
    g = gamma_abs
    formulas = {
        (0, 1): g(1) / math.sqrt(g(2 / 3) * g(4 / 3)),
        (0, 2): g(2 / 3) / math.sqrt(g(4 / 3)),
        (1, 2): g(1 / 3) / math.sqrt(g(2 / 3)),
    }
    printed = {(0, 1): "0.977", (0, 2): "0.880", (1, 2): "0.957"}
    for nu, sigma in [(3.0, 5.0), (0.1, 200.0)]:
        _, Phi = linearization(isl_gains(3, nu), isl_exponents(3), sigma)
        corr = Phi / np.sqrt(np.outer(np.diag(Phi), np.diag(Phi)))
        for (i, j), value in formulas.items():
            assert corr[i, j] == pytest.approx(value, rel=16 * EPS)
            assert f"{corr[i, j]:.3f}" == printed[i, j]


@pytest.mark.parametrize("m", range(1, M_MAX + 1))
def test_exponents_and_gains_follow_a17(m):
    i = np.arange(1, m + 1)
    q = isl_exponents(m)
    np.testing.assert_allclose(q, 1 - i / m, rtol=0, atol=EPS)
    nu = 2.5
    c = isl_gains(m, nu)
    expected = G_matrix(m)[:, 0] / np.sqrt([gamma_abs(2 * qi) for qi in q]) * nu ** (i / m)
    np.testing.assert_allclose(c, expected, rtol=4 * EPS)
    assert np.all(c > 0)


@settings(max_examples=40)
@given(m=st.integers(1, M_MAX), log_beta=st.floats(-2, 2), log_sigma=st.floats(-1, 3))
def test_phi_matches_kalman_bucy_gain_variance_for_every_sigma(m, log_beta, log_sigma):
    """(B.22–B.24): with ν = β, E φ_i(ξ)² = σ² K_i² for ξ ~ N(0, σ²) whatever σ (α = 0), K of (B.18)."""
    beta, sigma = 10.0**log_beta, 10.0**log_sigma
    _, Phi = linearization(isl_gains(m, beta), isl_exponents(m), sigma)
    K = kalman_bucy_alpha0(m, beta, sigma).K
    np.testing.assert_allclose(np.diag(Phi), sigma**2 * K**2, rtol=64 * EPS)


@pytest.mark.parametrize("m, sigma", [(1, 0.3), (3, 2.0), (3, 200.0), (6, 7.0)])
def test_linearization_closed_forms_against_quadrature(m, sigma):
    c, q = isl_gains(m, 1.7), isl_exponents(m)
    L, Phi = linearization(c, q, sigma)
    for i in range(m):
        li = gauss_expectation(lambda x, i=i: phi(x, c, q)[i] * x, sigma)  # (B.40)
        assert L[i] == pytest.approx(li, rel=10 * QUAD_TOL)
        for j in range(i, m):
            pij = gauss_expectation(lambda x, i=i, j=j: phi(x, c, q)[i] * phi(x, c, q)[j], sigma)  # (B.43)
            assert Phi[i, j] == pytest.approx(pij, rel=10 * QUAD_TOL)
            assert Phi[j, i] == Phi[i, j]


def test_linear_phi_moments():
    c = np.array([0.3, -1.2, 2.0])
    L, Phi = linearization(c, np.ones(3), 4.0)
    np.testing.assert_allclose(L, 16.0 * c, rtol=4 * EPS)
    np.testing.assert_allclose(Phi, 16.0 * np.outer(c, c), rtol=4 * EPS)


def test_phi_is_odd_zero_at_zero_and_vectorized():
    c, q = isl_gains(3, 3.0), isl_exponents(3)
    x = np.array([[-2.0, -1e-3, 0.0], [1e-3, 0.5, 8.0]])
    y = phi(x, c, q)
    assert y.shape == (2, 3, 3)
    np.testing.assert_array_equal(phi(-x, c, q), -y)
    np.testing.assert_array_equal(phi(0.0, c, q), np.zeros(3))
    np.testing.assert_allclose(phi(8.0, c, q), c * np.array([4.0, 2.0, 1.0]), rtol=4 * EPS)  # 8^{2/3}, 8^{1/3}, 1
    np.testing.assert_allclose(phi(-1.5, c, np.ones(3)), -1.5 * c, rtol=0)  # q = 1: the linear gain


@pytest.mark.parametrize("p", [-1.0, -2.0, math.nan, math.inf, None, "1", True])
def test_gamma_rejects_bad_p(p):
    with pytest.raises(ValueError, match=r"^p must be a finite number > -1"):
        gamma_abs(p)


@pytest.mark.parametrize("nu", [0.0, -1.0, math.nan, math.inf, None, "3", False])
def test_isl_gains_rejects_bad_nu(nu):
    with pytest.raises(ValueError, match=r"^nu must be a finite number > 0"):
        isl_gains(3, nu)


@pytest.mark.parametrize("sigma", [0.0, -1.0, math.nan, None])
def test_linearization_rejects_bad_sigma(sigma):
    with pytest.raises(ValueError, match=r"^sigma must be a finite number > 0"):
        linearization(np.ones(2), np.ones(2), sigma)


@pytest.mark.parametrize("m", [0, 7, 1.5, None])
def test_m_validated(m):
    with pytest.raises(ValueError, match=r"^m must be an integer"):
        isl_exponents(m)
    with pytest.raises(ValueError, match=r"^m must be an integer"):
        isl_gains(m, 1.0)


@pytest.mark.parametrize("beta", [0.5, 3.0, 20.0])
def test_the_m3_gains_at_nu_equal_beta_are_paper_bs_explicit_filter_b54(beta):
    gamma = lambda p: 2 ** (p / 2) * math.gamma((p + 1) / 2) / math.sqrt(math.pi)  # noqa: E731  E|U|^p
    b54 = [2 * beta ** (1 / 3) * gamma(4 / 3) ** -0.5, 2 * beta ** (2 / 3) * gamma(2 / 3) ** -0.5, beta]
    assert list(isl_gains(3, beta)) == pytest.approx(b54, rel=1e-12)
