"""Scenarios beyond constant σ and the clairvoyant reference (isl_core.scenario, :ref:`scenarios`)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import solve_discrete_are

from isl_core import Model, kalman_bucy
from isl_core.kernels.clairvoyant import clairvoyant_state, riccati_path
from isl_core.scenario import Scenario, clairvoyant, sigma_path

MODEL = Model.from_w(alpha=0.5, w=3.0, sigma=20.0, m=3)  # paper A's Fig. 3


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"sigma_knots": ((10.0, 2.0), (5.0, 20.0))}, "sigma step time #2"),
        ({"sigma_knots": ((0.0, 2.0),)}, "sigma step time #1"),
        ({"sigma_knots": ((10.0, 0.0),)}, "sigma after step #1"),
        ({"sigma_knots": ((10.0, math.nan),)}, "sigma after step #1"),
        ({"sigma_knots": ((10.0,),)}, "sigma_knots[0]"),
        ({"sigma_knots": 3.0}, "sigma_knots"),
        ({"sigma_shape": "ramp"}, "sigma_shape"),
        ({"noise": "cauchy"}, "noise"),
        ({"noise": "student", "dof": 2.0}, "dof"),
        ({"outlier_rate": 1.0}, "outlier_rate"),
        ({"outlier_scale": 0.5}, "outlier_scale"),
        ({"sensor_interval": -0.1}, "sensor_interval"),
        ({"sensor_interval": "0.1"}, "sensor_interval"),
    ],
)
def test_a_bad_scenario_is_refused_with_the_parameter_named(kwargs, named):
    with pytest.raises(ValueError, match=named.replace("[", r"\[").replace("]", r"\]")):
        Scenario(**kwargs)


def test_the_default_scenario_is_paper_a_model():
    s = Scenario()
    assert s.is_default and s.noise_variance == 1.0
    assert not Scenario(sigma_knots=((10.0, 2.0),)).is_default
    assert not Scenario(noise="student").is_default
    assert not Scenario(sensor_interval=0.1).is_default
    assert np.array_equal(s.sigma_at(20.0, np.array([0.0, 5.0, 1e5])), [20.0, 20.0, 20.0])


def test_sigma_steps_and_log_linear_drift_between_knots():
    knots = ((10.0, 2.0), (20.0, 200.0))
    t = np.array([0.0, 9.999, 10.0, 15.0, 20.0, 30.0])
    steps = Scenario(sigma_knots=knots).sigma_at(20.0, t)
    assert np.allclose(steps, [20.0, 20.0, 2.0, 2.0, 200.0, 200.0], rtol=1e-14)
    drift = Scenario(sigma_knots=knots, sigma_shape="drift").sigma_at(20.0, t)
    # log-linear: halfway from 20 to 2 in time is their geometric mean; halfway from 2 to 200 is 20
    assert np.allclose(drift, [20.0, 20.0 * 0.1**0.9999, 2.0, 20.0, 200.0, 200.0], rtol=1e-12)


def test_sigma_path_is_sigma_at_the_grid_times_in_units_of_one_over_r_min():
    kb = kalman_bucy(MODEL)
    h = 0.5 / kb.r_min
    path = sigma_path(Scenario(sigma_knots=((1.0, 2.0),)), MODEL, kb.r_min, h, 5)
    assert np.array_equal(path, [20.0, 20.0, 2.0, 2.0, 2.0])  # t_k r_min = 0, 0.5, 1, 1.5, 2


def _reference(model: Model, scenario: Scenario, h: float, n: int):
    """Textbook Kalman recursions for the same grid model, written apart from the module: q = 1 the predictor form,
    q > 1 the covariances of X, of S = h·Σ C X over the interval and between them, propagated term by term."""
    kb = kalman_bucy(model)
    q = scenario.sensor_steps(h, kb.r_min)
    sig = sigma_path(scenario, model, kb.r_min, h, n)
    F = np.eye(model.m) + h * model.A
    Q = h * model.beta**2 * (model.E @ model.E.T)
    H = h * model.C
    P = np.array(kb.delta, dtype=float)
    gains, var = np.zeros((n, model.m)), [np.diag(P).copy()]
    Pxs, Pss, R = np.zeros((model.m, 1)), 0.0, 0.0
    for k in range(n):
        r = h * sig[k] ** 2 * scenario.noise_variance
        if q == 1:
            s = (H @ P @ H.T).item() + r
            K = F @ P @ H.T / s
            P = F @ P @ F.T + Q - K @ K.T * s
            gains[k] = K[:, 0]
        else:
            R += r
            Pss = Pss + 2.0 * (H @ Pxs).item() + (H @ P @ H.T).item()  # Var(S + h X_1)
            Pxs = F @ (Pxs + P @ H.T)  # Cov(F X + w, S + h X_1)
            P = F @ P @ F.T + Q
            if (k + 1) % q == 0:
                K = Pxs / (Pss + R)
                P = P - K @ K.T * (Pss + R)
                gains[k] = K[:, 0]
                Pxs, Pss, R = np.zeros((model.m, 1)), 0.0, 0.0
        var.append(np.diag(P).copy())
    return gains, np.array(var), q


@pytest.mark.parametrize(
    "scenario",
    [
        Scenario(),
        Scenario(sigma_knots=((0.5, 2.0), (1.0, 200.0)), noise="student"),
        Scenario(sigma_knots=((0.5, 200.0),), sigma_shape="drift", noise="outliers", sensor_interval=0.05),
        Scenario(sensor_interval=0.1),
    ],
)
def test_clairvoyant_recursion_equals_a_textbook_kalman_filter(scenario):
    kb = kalman_bucy(MODEL)
    h = 0.01 / kb.r_min
    c = clairvoyant(MODEL, scenario, h, 300)
    gains, var, q = _reference(MODEL, scenario, h, 300)
    assert c.q == q
    assert np.allclose(c.gain, gains, rtol=1e-10, atol=0.0)
    assert np.allclose(c.var, var, rtol=1e-10, atol=0.0)
    if q > 1:  # no reading between sensor readings
        assert np.count_nonzero(np.any(c.gain != 0.0, axis=1)) == 300 // q


@pytest.mark.parametrize("sensor", [0.0, 0.05])
def test_a_settled_recursion_repeats_exactly_and_goes_on_when_sigma_changes(sensor):
    """Once settled (q = 1: a fixed point; q > 1: a cycle of q steps) the recursion is read back instead of run; a σ
    step restarts it from the state of the step before. Both, against the textbook recursion over the whole run."""
    kb = kalman_bucy(MODEL)
    h = 0.01 / kb.r_min
    scenario = Scenario(sigma_knots=((25.0, 2.0), (35.0, 20.0)), sensor_interval=sensor)
    n = 4500  # the steps at 2 500 and 3 500; settled from about step 2 000 (σ = 20) and 3 300 (σ = 2)
    q = scenario.sensor_steps(h, kb.r_min)
    state = clairvoyant_state(np.array(kb.delta, dtype=float), q)
    noise = h * sigma_path(scenario, MODEL, kb.r_min, h, 2400) ** 2
    riccati_path(state, h, MODEL.alpha, MODEL.beta**2, noise, q, np.zeros((2400, MODEL.m)), np.zeros((2401, MODEL.m)))
    assert state.flags[1] == 1.0  # settled before the first step
    c = clairvoyant(MODEL, scenario, h, n)
    gains, var, _ = _reference(MODEL, scenario, h, n)
    np.testing.assert_allclose(c.gain, gains, rtol=1e-10, atol=0.0)
    np.testing.assert_allclose(c.var, var, rtol=1e-10, atol=0.0)


def test_constant_sigma_settles_at_the_grids_stationary_filter_near_the_kalman_bucy_covariance():
    kb = kalman_bucy(MODEL)
    h = 0.02 / np.max(np.abs(kb.eig))
    n = int(40 / (kb.r_min * h))
    c = clairvoyant(MODEL, Scenario(), h, n)
    F = np.eye(MODEL.m) + h * MODEL.A
    dare = solve_discrete_are(
        F.T, h * MODEL.C.T, h * MODEL.beta**2 * (MODEL.E @ MODEL.E.T), np.array([[h * MODEL.sigma**2]])
    )
    assert np.allclose(c.var[-1], np.diag(dare), rtol=1e-9)
    # the grid's stationary filter is the Kalman–Bucy filter within the grid's O(h) bias
    assert np.allclose(np.sqrt(c.var[-1] / np.diag(kb.delta)), 1.0, atol=0.02)


@pytest.mark.parametrize(
    "scenario",
    [
        Scenario(sigma_knots=((0.3, 2.0),), noise="student", dof=5.0),
        Scenario(sigma_knots=((0.3, 200.0),), sigma_shape="drift", noise="outliers", sensor_interval=0.05),
    ],
)
def test_simulated_clairvoyant_errors_have_the_recursions_variance(scenario):
    """Many independent paths of the Euler truth and the clairvoyant filter (written out here, as the kernel will
    run it): the empirical error variance at each time is P_k within its sampling error."""
    kb = kalman_bucy(MODEL)
    h = 0.01 / kb.r_min
    n, paths = 120, 20_000
    c = clairvoyant(MODEL, scenario, h, n)
    rng = np.random.default_rng(11)
    sig = sigma_path(scenario, MODEL, kb.r_min, h, n)
    e = rng.standard_normal((paths, MODEL.m)) @ np.linalg.cholesky(np.array(kb.delta)).T  # e_0 ~ N(0, Δ)
    F = np.eye(MODEL.m) + h * MODEL.A
    acc = np.zeros(paths)  # the innovation of the current sensor interval
    worst = 0.0
    for k in range(n):
        v = rng.standard_normal(paths)
        eps = np.stack([scenario.draw_noise(rng, paths)])[0]
        acc += sig[k] * math.sqrt(h) * eps - h * e[:, 0]
        e = e @ F.T
        e[:, -1] -= MODEL.beta * math.sqrt(h) * v
        if np.any(c.gain[k] != 0.0):
            e += np.outer(acc, c.gain[k])
            acc[:] = 0.0
        emp = np.mean(e**2, axis=0)
        se = np.std(e**2, axis=0) / math.sqrt(paths)
        worst = max(worst, float(np.max(np.abs(emp - c.var[k + 1]) / se)))
    assert worst < 5.0
