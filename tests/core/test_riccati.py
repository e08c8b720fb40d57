"""Stationary Kalman–Bucy filter: CARE (A.23), closed form for α = 0 (B.16–B.18), paper values
(:ref:`reference-values`)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from isl_core import M_MAX, G_matrix, Model, care_residual, kalman_bucy, kalman_bucy_alpha0

EPS = np.finfo(float).eps


def norm(a) -> float:
    return float(np.linalg.norm(np.atleast_2d(a), 2))


def care_scale(model: Model, delta: np.ndarray) -> float:
    """Size of the terms of (A.23): the residual of a backward-stable solve is O(eps) times this."""
    return 2 * norm(model.A) * norm(delta) + model.beta**2 + norm(delta) ** 2 / model.sigma**2


def care_tol(model: Model, delta: np.ndarray) -> float:
    # a few rounding errors per entry of m×m products, summed over m terms: O(m²)·eps·scale
    return 8 * model.m**2 * EPS * care_scale(model, delta)


def test_G3_is_paper_b_value():
    expected = np.array([[2.0, 2.0, 1.0], [2.0, 3.0, 2.0], [1.0, 2.0, 2.0]])  # (B, §5)
    np.testing.assert_allclose(G_matrix(3), expected, rtol=0, atol=16 * EPS * norm(expected))


@pytest.mark.parametrize("m", range(1, M_MAX + 1))
def test_G_solves_a10_and_is_spd(m):
    g = G_matrix(m)
    model = Model(0.0, 1.0, 1.0, m)  # with β = σ = 1, (A.23) is (A.10)
    r = care_residual(model, g)
    assert norm(r) <= care_tol(model, g)
    np.testing.assert_array_equal(g, g.T)
    assert np.all(np.linalg.eigvalsh(g) > 0)
    g[0, 0] = -1.0  # a copy: the cached solution is untouched
    assert G_matrix(m)[0, 0] > 0


def test_G1_is_one():
    assert G_matrix(1)[0, 0] == pytest.approx(1.0, abs=4 * EPS)


@pytest.mark.parametrize("m", range(1, M_MAX + 1))
@pytest.mark.parametrize("beta, sigma", [(3.0, 5.0), (3.0, 50.0), (0.01, 1000.0), (100.0, 0.1)])
def test_alpha0_closed_form_matches_care(m, beta, sigma):
    # (B.16), (B.18) against the numerical CARE solution of (A.23)
    kb = kalman_bucy(Model(0.0, beta, sigma, m))
    cf = kalman_bucy_alpha0(m, beta, sigma)
    i = np.arange(1, m + 1)
    scale = np.sqrt(np.outer(np.diag(cf.delta), np.diag(cf.delta)))  # entries span many decades: compare each
    np.testing.assert_allclose(kb.delta / scale, cf.delta / scale, rtol=0, atol=64 * m * EPS)
    np.testing.assert_allclose(kb.K, cf.K, rtol=64 * m * EPS, atol=0)
    np.testing.assert_allclose(cf.K, G_matrix(m)[:, 0] * (beta / sigma) ** (i / m), rtol=8 * EPS)  # (B.18)
    assert kb.r_min == pytest.approx(cf.r_min, rel=1e3 * m * EPS)


@pytest.mark.parametrize("sigma, expected", [(5.0, 6.49), (50.0, 44.2)])
def test_sqrt_Q11_paper_b(sigma, expected):
    # paper B, §5: α = 0, m = 3, β = 3 → √Q_11 = √2·β^{1/6}·σ^{5/6} ≈ 6.49 (σ = 5), 44.2 (σ = 50)
    s1 = kalman_bucy(Model(0.0, 3.0, sigma, 3)).s[0]
    assert s1 == pytest.approx(math.sqrt(2) * 3.0 ** (1 / 6) * sigma ** (5 / 6), rel=64 * EPS)
    assert f"{s1:.3g}" == f"{expected:.3g}"  # the paper prints three significant digits


def test_m1_closed_form():
    # m = 1: Δ = βσ, K = β/σ, closed-loop eigenvalue −α − K with α = 0 … and the scalar CARE for α > 0
    kb = kalman_bucy(Model(0.0, 2.0, 8.0, 1))
    assert kb.delta[0, 0] == pytest.approx(16.0, rel=8 * EPS) and kb.r_min == pytest.approx(0.25, rel=8 * EPS)
    alpha, beta, sigma = 1.5, 2.0, 8.0
    kb = kalman_bucy(Model(alpha, beta, sigma, 1))
    d = sigma**2 * (-alpha + math.sqrt(alpha**2 + beta**2 / sigma**2))  # root of −2αΔ + β² − Δ²/σ² = 0
    assert kb.delta[0, 0] == pytest.approx(d, rel=16 * EPS)


@settings(max_examples=150)
@given(
    m=st.integers(1, M_MAX),
    alpha=st.one_of(st.just(0.0), st.floats(1e-3, 100.0)),
    log_beta=st.floats(-2.0, 2.0),
    log_sigma=st.floats(-1.0, 3.0),
)
def test_care_residual_spd_and_rate_for_random_models(m, alpha, log_beta, log_sigma):
    """The app's ranges: α ∈ [0, 100], β ∈ [1e-2, 1e2], σ ∈ [0.1, 1000], m = 1..6."""
    model = Model(alpha, 10.0**log_beta, 10.0**log_sigma, m)
    kb = kalman_bucy(model)
    d = kb.delta
    assert norm(care_residual(model, d)) <= care_tol(model, d)  # (A.23)
    np.testing.assert_array_equal(d, d.T)
    corr = d / np.sqrt(np.outer(np.diag(d), np.diag(d)))  # SPD is invariant under diagonal scaling
    assert np.linalg.eigvalsh(corr).min() > m * EPS
    np.testing.assert_allclose(kb.s, np.sqrt(np.diag(d)), rtol=0)
    np.testing.assert_allclose(kb.K, d[:, 0] / model.sigma**2, rtol=EPS)  # K = σ⁻²ΔCᵀ (A.21)
    closed = model.A - np.outer(kb.K, model.C[0])
    np.testing.assert_allclose(np.sum(kb.eig), np.trace(closed), rtol=1e-9, atol=1e-9 * norm(closed))
    assert np.all(kb.eig.real < 0)  # A − KC is Hurwitz: the filter settles
    assert kb.r_min > 0 and kb.r_min == np.min(-kb.eig.real)  # (A.24)


def test_results_are_read_only():
    kb = kalman_bucy(Model(0.5, 3.0, 20.0, 3))
    for arr in (kb.K, kb.delta, kb.s, kb.eig):
        with pytest.raises(ValueError):
            arr[0] = 0.0


@pytest.mark.parametrize("bad", [None, "model", 3, (0.5, 3.0, 20.0, 3)])
def test_kalman_bucy_rejects_non_models(bad):
    with pytest.raises(ValueError, match=r"^model must be an isl_core.Model"):
        kalman_bucy(bad)


@pytest.mark.parametrize("m", [0, 7, 2.5, None, "3", True])
def test_G_matrix_rejects_bad_m(m):
    with pytest.raises(ValueError, match=r"^m must be an integer"):
        G_matrix(m)


@pytest.mark.parametrize("args, name", [((3, 0.0, 1.0), "beta"), ((3, 1.0, math.nan), "sigma"), ((9, 1.0, 1.0), "m")])
def test_alpha0_closed_form_validates(args, name):
    with pytest.raises(ValueError, match=f"^{name} must be"):
        kalman_bucy_alpha0(*args)
