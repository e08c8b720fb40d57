"""Scenarios beyond constant σ and the clairvoyant reference (isl_core.scenario, SPEC §9)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats
from scipy.linalg import solve_discrete_are

from isl_core import Model, kalman_bucy
from isl_core.noise import student_table
from isl_core.scenario import Scenario, _riccati, clairvoyant, clairvoyant_state, sigma_path

MODEL = Model.from_w(alpha=0.5, w=3.0, sigma=20.0, m=3)  # paper A's Fig. 3


@pytest.mark.parametrize(("kwargs", "named"), [
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
])
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
    assert np.allclose(drift, [20.0, 20.0 * 0.1 ** 0.9999, 2.0, 20.0, 200.0, 200.0], rtol=1e-12)


def test_sigma_path_is_sigma_at_the_grid_times_in_units_of_one_over_r_min():
    kb = kalman_bucy(MODEL)
    h = 0.5 / kb.r_min
    path = sigma_path(Scenario(sigma_knots=((1.0, 2.0),)), MODEL, kb.r_min, h, 5)
    assert np.array_equal(path, [20.0, 20.0, 2.0, 2.0, 2.0])  # t_k r_min = 0, 0.5, 1, 1.5, 2


@pytest.mark.parametrize(("scenario", "variance"), [
    (Scenario(noise="student", dof=3.0), 1.0),
    (Scenario(noise="student", dof=10.0), 1.0),
    (Scenario(noise="outliers", outlier_rate=0.01, outlier_scale=30.0), 0.99 + 0.01 * 900.0),
])
def test_noise_laws_have_the_documented_variance(scenario, variance):
    eps = scenario.draw_noise(np.random.default_rng(7), 400_000)
    assert scenario.noise_variance == pytest.approx(variance)
    # 6 standard errors of the sample variance (its fourth moment measured; for t_3 it is infinite, so the
    # batch of 400 000 only bounds it loosely: use the median-based check below instead)
    if scenario.noise == "student" and scenario.dof <= 4:
        # t_3 scaled to unit variance: its median |ε| is √(1/3)·0.7649 (the t_3 quartile)
        assert np.median(np.abs(eps)) == pytest.approx(math.sqrt(1 / 3) * 0.764892, rel=0.01)
    else:
        se = np.std(eps**2) / math.sqrt(len(eps))
        assert abs(np.mean(eps**2) - variance) < 6 * se
    if scenario.noise == "outliers":
        assert np.mean(np.abs(eps) > 8.0) == pytest.approx(0.01 * math.erfc(8 / 30 / math.sqrt(2)), rel=0.1)


@pytest.mark.parametrize("dof", [2.1, 3.0, 7.5, 40.0])
def test_student_noise_has_the_t_law_in_the_tails_too(dof):
    """The ziggurat's draws against scipy's t_d: the whole law (Kolmogorov–Smirnov, 10⁶ draws; a layer's wrong edge
    or height moves the statistic far beyond its 1e-4 quantile) and the two tails where a heavy-tailed law differs
    from a Gaussian of the same variance: beyond the 10⁻³ quantile, and beyond the 10⁻⁴ one, past the ziggurat's
    base edge r, drawn from its envelope there (a tail cut at the base layer's width leaves none)."""
    scale = math.sqrt((dof - 2.0) / dof)
    t = Scenario(noise="student", dof=dof).draw_noise(np.random.default_rng(3), 1_000_000) / scale
    assert stats.kstest(t, stats.t(dof).cdf).pvalue > 1e-4
    for p, tolerance in ((1e-3, 0.1), (1e-4, 0.35)):  # about 3.2 and 3.5 standard errors (2000 and 200 expected)
        far = stats.t(dof).isf(p / 2.0)
        assert np.mean(np.abs(t) > far) == pytest.approx(p, rel=tolerance)
    assert stats.t(dof).isf(5e-5) > student_table(dof)[1, 0]  # the second tail is beyond r


@pytest.mark.parametrize("rate", [0.3, 0.01])
def test_outliers_fall_on_independent_steps_at_the_rate(rate):
    """Each step is an outlier with probability p, independently (isl_core.noise): the rate, the rate of two in a
    row (p²) and the first step's rate over many runs — each within 4 standard errors."""
    scenario = Scenario(noise="outliers", outlier_rate=rate, outlier_scale=3.0)
    unscaled = Scenario(noise="outliers", outlier_rate=rate, outlier_scale=1.0)  # the same draws, k = 1

    def outliers(seed, n):  # exactly the steps scaled by k: which ones does not depend on k
        drawn, plain = (s.draw_noise(np.random.default_rng(seed), n) for s in (scenario, unscaled))
        assert np.all((drawn == plain) | (drawn == 3.0 * plain))  # every ε is N(0,1) or k times it
        return drawn != plain

    hit = outliers(5, 400_000)
    n = hit.size

    def close(x, p, m):
        return abs(x - p) < 4.0 * math.sqrt(p * (1.0 - p) / m)

    assert close(hit.mean(), rate, n) and close(np.mean(hit[1:] & hit[:-1]), rate * rate, n)
    first = [outliers(seed, 1)[0] for seed in range(4000)]
    assert close(np.mean(first), rate, 4000)


@pytest.mark.parametrize("dof", [2.1, 3.0, 7.5, 40.0, 1e4])
def test_the_student_ziggurat_has_layers_of_equal_area_under_the_density(dof):
    """Each of the 256 layers (width × height) has the base layer's area v = r·f(r) + ∫_r^∞ f, its inner edge where
    f reaches its top, and the layers stack from f(r) to f(0) = 1 — with f = t_d's density over its value at 0,
    the tail from scipy. A narrower layer, a raised inner edge or a wrong height each breaks one of these."""
    tab = student_table(dof)
    law = stats.t(dof)

    def f(x):
        return law.pdf(x) / law.pdf(0.0)

    width, inner, low, high = tab
    r = inner[0]
    v = r * f(r) + law.sf(r) / law.pdf(0.0)
    assert width[0] * high[0] == pytest.approx(v, rel=1e-12) and high[0] == pytest.approx(f(r), rel=1e-12)
    assert np.allclose(width[1:] * (high[1:] - low[1:]), v, rtol=1e-9, atol=0.0)
    assert width[1] == r and np.array_equal(width[2:], inner[1:-1]) and np.array_equal(low[1:], high[:-1])
    assert np.allclose(f(inner[1:-1]), high[1:-1], rtol=1e-12, atol=0.0)
    assert inner[-1] == 0.0 and high[-1] == 1.0 and np.all(np.diff(inner[:-1]) < 0.0)


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
            Pxs = F @ (Pxs + P @ H.T)                              # Cov(F X + w, S + h X_1)
            P = F @ P @ F.T + Q
            if (k + 1) % q == 0:
                K = Pxs / (Pss + R)
                P = P - K @ K.T * (Pss + R)
                gains[k] = K[:, 0]
                Pxs, Pss, R = np.zeros((model.m, 1)), 0.0, 0.0
        var.append(np.diag(P).copy())
    return gains, np.array(var), q


@pytest.mark.parametrize("scenario", [
    Scenario(),
    Scenario(sigma_knots=((0.5, 2.0), (1.0, 200.0)), noise="student"),
    Scenario(sigma_knots=((0.5, 200.0),), sigma_shape="drift", noise="outliers", sensor_interval=0.05),
    Scenario(sensor_interval=0.1),
])
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
    _riccati(*state, h, MODEL.alpha, MODEL.beta**2, noise, q, np.zeros((2400, MODEL.m)), np.zeros((2401, MODEL.m)))
    assert state[1][1] == 1.0  # settled before the first step
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
    dare = solve_discrete_are(F.T, h * MODEL.C.T, h * MODEL.beta**2 * (MODEL.E @ MODEL.E.T),
                              np.array([[h * MODEL.sigma**2]]))
    assert np.allclose(c.var[-1], np.diag(dare), rtol=1e-9)
    # the grid's stationary filter is the Kalman–Bucy filter within the grid's O(h) bias
    assert np.allclose(np.sqrt(c.var[-1] / np.diag(kb.delta)), 1.0, atol=0.02)


@pytest.mark.parametrize("scenario", [
    Scenario(sigma_knots=((0.3, 2.0),), noise="student", dof=5.0),
    Scenario(sigma_knots=((0.3, 200.0),), sigma_shape="drift", noise="outliers", sensor_interval=0.05),
])
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
