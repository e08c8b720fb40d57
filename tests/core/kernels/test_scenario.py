"""The compiled scenario loop (isl_core.kernels.scenario) against the same step written out in numpy, one filter at a
time, with gains that owe nothing to the code under test: the Kalman–Bucy and adaptive gains from scipy's CARE, the
ISL coefficients from the papers' formula (tests/_reference.py), the clairvoyant filter's from the Kalman filter of
the Euler grid written out below, Huber's κ(c) from the normal law."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _reference import care, isl_coefficients, kbf_gain
from scipy.stats import norm

from isl_core import Model, adaptive_kbf, isl_filter, kalman_bucy, optimal_kbf
from isl_core._engine import draw_start
from isl_core.filters.base import FilterSpec
from isl_core.filters.robust import robust_kbf
from isl_core.kernels.draws import DRAWS, draw_ahead
from isl_core.scenario import Scenario, sigma_path
from isl_core.scenario.run import simulate_scenario

MODEL = Model.from_w(alpha=0.5, w=3.0, sigma=20.0, m=3)  # paper A's Fig. 3


def _draws(rng, scenario: Scenario, n: int):
    """v_k and ε_k of n steps as the loop draws them: the core's draws of the noise law (isl_core.noise; its laws
    are tested in test_scenario), in its blocks of DRAWS steps — the filters are what this loop checks."""
    v, eps = np.empty(n), np.empty(n)
    for k in range(0, n, DRAWS):
        draw_ahead(rng, scenario.noise_law(), v[k:], eps[k:], min(DRAWS, n - k))
    return v, eps


def _kappa(c: float) -> float:
    """κ(c) = E min(Z², c²), Z ~ N(0, 1): (2Φ(c) − 1) − 2cφ(c) + 2c²(1 − Φ(c))."""
    return (2.0 * norm.cdf(c) - 1.0) - 2.0 * c * norm.pdf(c) + 2.0 * c * c * norm.sf(c)


def _clairvoyant_gains(model: Model, sig: np.ndarray, h: float, q: int, noise_var: float) -> np.ndarray:
    """The Kalman filter of the Euler grid that knows σ_k (:ref:`clairvoyant`), on (X, S), S the increment of Y since
    the last reading: P ← F P Fᵀ + hβ²EEᵀ with X ← (I + hA)X, S ← S + hX₁; at a reading (every q steps) the gain
    P_XS/(P_SS + R), R = Σ h σ_k² E ε² since the last one, then S restarts at 0. Started at the CARE's Δ at σ(0)."""
    m, n = model.m, len(sig)
    P = np.zeros((m + 1, m + 1))
    P[:m, :m] = care(model.alpha, model.beta, model.sigma, m)
    F = np.eye(m + 1)
    F[:m, :m] += h * model.A
    F[m, 0] = h
    gains, R = np.zeros((n, m)), 0.0
    for k in range(n):
        R += h * sig[k] ** 2 * noise_var
        P = F @ P @ F.T
        P[m - 1, m - 1] += h * model.beta**2
        if (k + 1) % q == 0:
            s = P[m, m] + R
            gains[k] = P[:m, m] / s
            P[:m, :m] -= np.outer(P[:m, m], P[:m, m]) / s
            P[m, :], P[:, m], R = 0.0, 0.0, 0.0
    return gains


def _table_gain(spec: FilterSpec):
    """K(σ̂) of an adaptive filter: the CARE gain (scipy) at the nodes of its table, log K linear in log σ between them
    and held beyond the ends (:mod:`isl_core.filters.adaptive`)."""
    nodes = spec.adaptive.sigmas
    m = len(spec.coef)
    log_k = np.log([kbf_gain(MODEL.alpha, MODEL.beta, s, m) for s in nodes])
    return lambda s: np.exp([np.interp(math.log(s), np.log(nodes), col) for col in log_k.T])


def _loop(model, filters, scenario, h, n, seed, q):
    """The scenario step written out in numpy, one filter at a time (module docstring of isl_core.kernels.scenario)."""
    kb = kalman_bucy(model)
    rng = np.random.default_rng(seed)
    x, e0 = draw_start(model, kb, rng, "stationary")
    e = np.tile(e0, (len(filters), 1))
    sig = sigma_path(scenario, model, kb.r_min, h, n)
    gains = _clairvoyant_gains(model, sig, h, q, scenario.noise_variance)
    learns = {f: _table_gain(spec) for f, spec in enumerate(filters) if spec.adaptive is not None}
    est = [spec.adaptive.sigma_init**2 if spec.adaptive is not None else 0.0 for spec in filters]
    coef = [np.zeros(model.m), kbf_gain(model.alpha, model.beta, model.sigma, model.m), isl_coefficients(model.m, 3.0)]
    coef += [learns[f](spec.adaptive.sigma_init) for f, spec in enumerate(filters) if f >= 3]
    acc = np.zeros(len(filters))
    sq = np.zeros((len(filters), model.m))
    gain = [math.sqrt(q * h) * c for c in coef]
    readings = 0
    m = model.m
    s_hats = [f.adaptive.sigma_init if f.adaptive is not None else 0.0 for f in filters]
    vs, epss = _draws(rng, scenario, n)
    for k in range(n):
        v, eps = vs[k], epss[k]
        reading = (k + 1) % q == 0
        readings += reading
        xm = x[-1]
        for f, spec in enumerate(filters):
            acc[f] += sig[k] * eps - math.sqrt(h) * e[f, 0]
            A_f = np.eye(m, k=1)
            A_f[-1, -1] = -spec.damp
            e[f] = e[f] + h * (A_f @ e[f])
            e[f, -1] += h * (model.alpha - spec.damp) * xm - model.beta * math.sqrt(h) * v
            if reading:
                u = acc[f] / math.sqrt(q)
                if f == 0:  # the clairvoyant filter
                    e[f] += gains[k] * (math.sqrt(h) * acc[f])
                elif spec.power:
                    e[f] += gain[f] * np.sign(u) * np.abs(u) ** (1.0 - np.arange(1, m + 1) / m)
                else:
                    uc, uu = u, u * u
                    if spec.huber is not None:  # Huber's ψ at ±c·σ̂, the clipped square made consistent
                        lim = spec.huber * s_hats[f]
                        uc = float(np.clip(u, -lim, lim))
                        uu = min(u * u, lim * lim) / _kappa(spec.huber)
                    e[f] += gain[f] * uc
                    if spec.adaptive is not None:
                        lam = max(1.0 / readings, 1.0 / spec.adaptive.memory)
                        est[f] += lam * (uu - est[f])
                        bias = 1.0 + q * h * gain[f][0] / math.sqrt(q * h)
                        s_hat = math.sqrt(est[f] / bias)
                        lo, hi = spec.adaptive.sigma_range  # σ̂ held in the range the filter states, its state too
                        if not lo <= s_hat <= hi:
                            s_hat = min(max(s_hat, lo), hi)
                            est[f] = s_hat * s_hat * bias
                        gain[f] = math.sqrt(q * h) * learns[f](s_hat)
                        s_hats[f] = s_hat
                acc[f] = 0.0
            sq[f] += e[f] ** 2
        x[-1] = (1.0 - h * model.alpha) * xm + model.beta * math.sqrt(h) * v
    return sq


@pytest.mark.parametrize(
    "scenario",
    [
        Scenario(sigma_knots=((0.3, 2.0),), noise="student", dof=4.0),
        Scenario(
            sigma_knots=((0.3, 200.0),), sigma_shape="drift", noise="outliers", outlier_rate=0.05, sensor_interval=0.02
        ),
        Scenario(sensor_interval=0.03),
    ],
)
def test_the_compiled_scenario_loop_equals_a_plain_loop(scenario):
    extra = [adaptive_kbf(MODEL), robust_kbf(MODEL, c=1.0)]
    run = simulate_scenario(MODEL, 3.0, scenario, horizon=0.6, windows=7, seed=5, extra=extra)
    kb = kalman_bucy(MODEL)
    filters = [
        FilterSpec("clairvoyant", "clairvoyant", MODEL.alpha, np.zeros(MODEL.m), False),
        optimal_kbf(MODEL, kb),
        isl_filter(MODEL, 3.0),
        *extra,
    ]
    sq = _loop(MODEL, filters, scenario, run.h, run.N, 5, run.q)
    got = np.tensordot(run.steps.astype(float), run.mse, axes=1)
    assert (scenario.sensor_interval == 0) == (run.q == 1)
    assert np.allclose(got, sq, rtol=1e-10, atol=0.0)
