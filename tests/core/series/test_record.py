"""The recorded series: validation at the boundary (rows named, the fix said) and the reading model's σ."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isl_core.series import Series, series, sigma_of_reading
from isl_core.series.discretize import steps, van_loan
from isl_core.series.record import MIN_READINGS

T = np.arange(12.0)
Z = np.linspace(0.0, 1.0, 12)


@pytest.mark.parametrize(
    ("t", "z", "message"),
    [
        (np.r_[0.0, 2.0, 1.0, T[3:]], Z, "row 3 has t = 1 after t = 2 in row 2 (sort the rows"),
        (np.r_[0.0, 1.0, 1.0, T[3:]], Z, "row 3 has t = 1 after t = 1 in row 2"),
        (np.r_[T[:4], np.nan, T[5:]], Z, "times must be finite numbers: row 5"),
        (T, np.r_[Z[:6], np.inf, Z[7:]], "readings must be finite or missing: row 7"),
        (T, np.r_[Z[:2], 1e200, Z[3:]], "row 3 has 1e+200 (rescale the unit)"),
        (T, np.r_[Z[:3], np.full(9, np.nan)], f"at least {MIN_READINGS} readings present, got 3"),
        (T[:5], Z, "the same length, got 5 and 12"),
        ([*T[:3], "x", *T[4:]], Z, "times must be numbers: row 4 has 'x'"),
    ],
)
def test_refusals_name_the_row_and_the_fix(t, z, message):
    with pytest.raises(ValueError, match=None) as err:
        series(t, z)
    assert message in str(err.value)


def test_missing_readings_and_irregular_times_are_kept():
    z = np.r_[Z[:4], np.nan, Z[5:]]
    t = np.r_[T[:6], T[6:] + 0.5]
    s = series(t, z, name="x", unit="s")
    assert isinstance(s, Series) and s.n == 12 and int(s.present.sum()) == 11
    assert not s.regular and s.spacing == 1.0 and series(T, Z).regular


def test_van_loan_matches_the_integral_and_the_local_level():
    """Q = ∫ expm(As) β²EEᵀ expm(As)ᵀ ds by quadrature; for m = 1, α = 0: F = 1, Q = β²Δ (the local level)."""
    from scipy.integrate import quad_vec
    from scipy.linalg import expm

    m, alpha, beta, dt = 3, 0.7, 1.3, 0.8
    F, Q = van_loan(m, alpha, beta, np.array([dt]))
    A = np.eye(m, k=1)
    A[-1, -1] = -alpha
    E = np.zeros((m, 1))
    E[-1] = 1.0
    ref, _ = quad_vec(lambda s: expm(A * s) @ (beta**2 * E @ E.T) @ expm(A * s).T, 0.0, dt, epsabs=1e-14)
    np.testing.assert_allclose(F[0], expm(A * dt), rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(Q[0], ref, rtol=1e-10, atol=1e-14)
    F1, Q1 = van_loan(1, 0.0, 2.0, np.array([0.5, 3.0]))
    np.testing.assert_allclose(F1[:, 0, 0], 1.0)
    np.testing.assert_allclose(Q1[:, 0, 0], [2.0, 12.0])


def test_equal_intervals_share_one_matrix():
    st = steps(np.r_[0.1 * np.arange(1000), 200.0])
    assert len(st.dt) == 2 and st.index[0] == 0 and st.index[-1] != st.index[1]


def test_an_averaged_continuous_observation_is_a_reading_of_variance_sigma2_over_delta():
    """dY = X₁dt + σdε on a fine grid (q steps of h per interval Δ), with X₁ = 0: (Y(t+Δ) − Y(t))/Δ has variance
    σ²/Δ, so σ = σ_r·√Δ (:func:`sigma_of_reading`); tolerance: the sample variance's sd √(2/n), five of them."""
    rng = np.random.default_rng(0)
    sigma, h, q, n = 3.0, 1e-3, 50, 20_000
    dY = sigma * math.sqrt(h) * rng.standard_normal((n, q))
    readings = dY.sum(axis=1) / (q * h)
    ratio = readings.var() / (sigma**2 / (q * h))
    assert abs(ratio - 1.0) < 5.0 * math.sqrt(2.0 / n)
    assert sigma_of_reading(math.sqrt(readings.var()), q * h) == pytest.approx(sigma, rel=5.0 * math.sqrt(0.5 / n))
