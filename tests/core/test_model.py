"""The model (A.1–A.6, A.19–A.20, A.25): matrices, the w-parametrization, and validation at construction."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from isl_core import M_MAX, Model

BAD_REAL = [math.nan, math.inf, -math.inf, None, "3", True, False, 1 + 2j, [1.0], np.array([1.0, 2.0])]


@pytest.mark.parametrize("m", range(1, M_MAX + 1))
def test_matrices_follow_a1_a6(m):
    model = Model(alpha=0.7, beta=2.0, sigma=5.0, m=m)
    A0, A, E, C = model.A0, model.A, model.E, model.C
    assert A0.shape == A.shape == (m, m) and E.shape == (m, 1) and C.shape == (1, m)
    for i in range(m):  # dX_i = X_{i+1} dt: ones exactly on the superdiagonal (A.11)
        for j in range(m):
            assert A0[i, j] == (1.0 if j == i + 1 else 0.0)
    np.testing.assert_array_equal(E[:, 0], np.eye(m)[-1])  # E = e_m
    np.testing.assert_array_equal(C[0], np.eye(m)[0])  # C = e_1ᵀ
    np.testing.assert_array_equal(A, A0 - model.alpha * E @ E.T)  # (A.20)


def test_matrices_are_fresh_copies():
    model = Model(0.5, 3.0, 20.0, 3)
    model.A[0, 0] = 99.0
    model.A0[0, 1] = 99.0
    assert model.A[0, 0] == 0.0 and model.A0[0, 1] == 1.0


def test_model_is_frozen_and_normalizes_types():
    model = Model(np.float64(1), 2, np.float32(3.0), 3.0)
    assert type(model.alpha) is float and type(model.beta) is float and type(model.sigma) is float
    assert type(model.m) is int and model.m == 3
    with pytest.raises(dataclasses.FrozenInstanceError):
        model.sigma = 1.0


def test_from_w_is_paper_a_parametrization():
    # (A.25): β²/(2α) = w², i.e. the stationary variance of X_m is w²
    for alpha in (0.04, 0.2, 1.0, 5.0, 25.0):
        model = Model.from_w(alpha, 3.0, 20.0, 3)
        assert model.beta == pytest.approx(3.0 * math.sqrt(2.0 * alpha), rel=4 * np.finfo(float).eps)
        assert model.stationary_var == pytest.approx(9.0, rel=4 * np.finfo(float).eps)
    assert Model(0.0, 1.0, 1.0, 1).stationary_var == math.inf


def test_from_w_rejects_alpha_zero_with_a_clear_message():
    with pytest.raises(ValueError, match=r"alpha must be .*> 0.*β = w·√\(2α\)"):
        Model.from_w(0.0, 3.0, 20.0, 3)


@pytest.mark.parametrize("name", ["alpha", "beta", "sigma"])
@pytest.mark.parametrize("value", [*BAD_REAL, -1.0, -1e-300])
def test_bad_real_parameters_raise_naming_them(name, value):
    kwargs = {"alpha": 0.5, "beta": 3.0, "sigma": 20.0, "m": 3}
    kwargs[name] = value
    with pytest.raises(ValueError, match=rf"^{name} must be a finite number >=? 0"):
        Model(**kwargs)


@pytest.mark.parametrize("name", ["beta", "sigma"])
def test_beta_and_sigma_must_be_positive(name):
    kwargs = {"alpha": 0.5, "beta": 3.0, "sigma": 20.0, "m": 3}
    kwargs[name] = 0.0
    with pytest.raises(ValueError, match=rf"^{name} must be a finite number > 0, got 0.0"):
        Model(**kwargs)


def test_alpha_zero_is_allowed():
    assert Model(0.0, 3.0, 5.0, 3).alpha == 0.0


@pytest.mark.parametrize("m", [0, 7, -1, 2.5, math.nan, math.inf, None, "3", True, 3 + 0j])
def test_bad_m_raises_naming_it(m):
    with pytest.raises(ValueError, match=rf"^m must be an integer >= 1 and <= {M_MAX}"):
        Model(0.5, 3.0, 20.0, m)


@pytest.mark.parametrize(
    "name, value",
    [("alpha", math.nan), ("alpha", -1.0), ("w", 0.0), ("w", math.inf), ("w", "3"), ("sigma", None), ("m", 7)],
)
def test_from_w_bad_inputs_name_the_parameter(name, value):
    kwargs = {"alpha": 0.5, "w": 3.0, "sigma": 20.0, "m": 3}
    kwargs[name] = value
    with pytest.raises(ValueError, match=rf"^{name} must be"):
        Model.from_w(**kwargs)
