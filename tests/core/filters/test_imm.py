"""The interacting-multiple-model filter (isl_core.filters.imm) against a plain implementation of Blom & Bar-Shalom's
cycle."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import norm

from isl_core import Model, Scenario, kalman_bucy, simulate, simulate_scenario
from isl_core._engine import draw_start
from isl_core.filters.imm import imm_kbf
from isl_core.kernels.draws import DRAWS, draw_ahead
from isl_core.scenario import sigma_path

MODEL = Model.from_w(1.0, 3.0, 20.0, 3)


def _draws(rng, scenario: Scenario, n: int):
    """v_k and ε_k as the scenario loop draws them (blocks of DRAWS steps; the laws are tested in test_scenario)."""
    v, eps = np.empty(n), np.empty(n)
    for k in range(0, n, DRAWS):
        draw_ahead(rng, scenario.noise_law(), v[k:], eps[k:], min(DRAWS, n - k))
    return v, eps


def _imm_reference(model, spec, scenario, h, n, seed, q):
    """The IMM cycle in state coordinates (X̂_j, P_j, μ_j) on the state (X, S) of the sensor interval, S = h Σ C X:
    mixing of the filtered estimates (not at the start: the bank starts as after one), prediction over q steps,
    update with ΔY, mode probabilities from N(r_j; 0, s_j), combination; the truth on the Euler grid (B.33–B.34).
    Returns the squared errors of Σ_j μ_j X̂_j summed over the steps, and the sum of Σ_j μ_j σ_j."""
    kb = kalman_bucy(model)
    rng = np.random.default_rng(seed)
    x, e0 = draw_start(model, kb, rng, "stationary")
    m, bank = model.m, spec.imm
    J, p = len(bank.sigmas), bank.switch
    T = np.full((J, J), p / (J - 1) if J > 1 else 0.0)  # T[i, j] = P(mode j after mode i)
    np.fill_diagonal(T, 1.0 - p)
    X = np.zeros(m)
    X[-1] = x[-1]
    F = np.eye(m) + h * model.A
    Fa = np.block([[F, np.zeros((m, 1))], [h * model.C, np.ones((1, 1))]])
    Qa = np.zeros((m + 1, m + 1))
    Qa[m - 1, m - 1] = h * model.beta**2
    xs = [np.append(X + e0, 0.0) for _ in range(J)]
    Ps = [np.pad(c, ((0, 1), (0, 1))) for c in bank.cov]
    mu = post = np.full(J, 1.0 / J)  # post: the weights after the last reading (σ̂ = Σ post_j σ_j)
    sig = sigma_path(scenario, model, kb.r_min, h, n)
    v, eps = _draws(rng, scenario, n)
    dY, sq, s_hat = 0.0, np.zeros(m), 0.0
    for k in range(n):
        dY += h * X[0] + sig[k] * math.sqrt(h) * eps[k]  # the increment of Y since the last reading (B.34)
        X = F @ X
        X[-1] += model.beta * math.sqrt(h) * v[k]
        xs = [Fa @ xa for xa in xs]
        Ps = [Fa @ P @ Fa.T + Qa for P in Ps]
        if (k + 1) % q == 0:
            like = np.empty(J)
            for j in range(J):
                r, s = dY - xs[j][m], Ps[j][m, m] + q * h * bank.sigmas[j] ** 2
                K = Ps[j][:, m] / s
                like[j] = norm.pdf(r, scale=math.sqrt(s))
                xs[j] = xs[j] + K * r
                Ps[j] = Ps[j] - np.outer(K, K) * s
                xs[j][m], Ps[j][m, :], Ps[j][:, m] = 0.0, 0.0, 0.0  # S restarts, known
            mu = post = like * mu / (like * mu).sum()  # mu held c̄ (Blom & Bar-Shalom (8)-(9))
            combined = sum(mu[j] * xs[j][:m] for j in range(J))  # (10)
            sq += (combined - X) ** 2
            s_hat += post @ bank.sigmas
            cbar = T.T @ mu  # mixing (6)-(7), for the next interval
            w = T * mu[:, None] / cbar[None, :]  # w[i, j] = μ_i|j
            x0 = [sum(w[i, j] * xs[i] for i in range(J)) for j in range(J)]
            Ps = [sum(w[i, j] * (Ps[i] + np.outer(xs[i] - x0[j], xs[i] - x0[j])) for i in range(J)) for j in range(J)]
            xs, mu, dY = x0, cbar, 0.0
        else:
            sq += (sum(mu[j] * xs[j][:m] for j in range(J)) - X) ** 2
            s_hat += post @ bank.sigmas
    return sq, s_hat


@pytest.mark.parametrize(
    ("scenario", "horizon"),
    [
        (Scenario(sigma_knots=((0.5, 2.0),)), 1.5),
        (
            Scenario(
                sigma_knots=((0.4, 200.0),),
                sigma_shape="drift",
                noise="outliers",
                outlier_rate=0.05,
                sensor_interval=0.05,
            ),
            1.2,
        ),
    ],
)
def test_the_compiled_bank_equals_blom_and_bar_shaloms_cycle_written_out(scenario, horizon):
    spec = imm_kbf(MODEL, modes=5, switch=0.03)
    run = simulate_scenario(MODEL, 3.0, scenario, horizon=horizon, windows=4, seed=7, extra=[spec])
    sq, s_hat = _imm_reference(MODEL, spec, scenario, run.h, run.N, 7, run.q)
    got = np.tensordot(run.steps.astype(float), run.mse, axes=1)[3]
    assert np.allclose(got, sq, rtol=1e-10, atol=0.0), (got, sq)
    assert run.steps @ run.sigma_hat[:, 0] == pytest.approx(s_hat, rel=1e-10)


@pytest.mark.parametrize("scenario", [Scenario(), Scenario(sensor_interval=0.05)])
def test_one_mode_at_the_true_sigma_is_the_clairvoyant_kalman_filter(scenario):
    """A bank of one mode never mixes: it is the grid's Kalman filter with that σ, started at Δ (A.23) — the
    clairvoyant filter of a constant σ, step for step (windows of one step: a squared error near a zero crossing
    is compared with the run's mean square as its scale)."""
    one = imm_kbf(MODEL, sigma_range=(MODEL.sigma, MODEL.sigma), modes=1)
    run = simulate_scenario(MODEL, 3.0, scenario, horizon=2.0, windows=100_000, seed=4, extra=[one])
    assert np.all(run.steps == 1)
    scale = run.mse[:, 0].mean(axis=0)
    assert np.all(np.abs(run.mse[:, 3] - run.mse[:, 0]) <= 1e-12 * (run.mse[:, 0] + scale))


def test_the_bank_learns_a_drop_of_sigma_and_its_weights_never_all_underflow():
    """After a 10-fold drop the weights move to the modes near the new σ. A bank whose every mode is far from the
    truth (σ = 20 against modes of 0.01–0.02: each reading is 10⁴ standard deviations out) still has finite weights
    (the exponents are shifted by the best mode's) and follows its top mode."""
    run = simulate_scenario(
        MODEL, 3.0, Scenario(sigma_knots=((1.0, 2.0),)), horizon=3.0, windows=3, seed=2, extra=[imm_kbf(MODEL)]
    )
    assert run.sigma_hat[0, 0] > 10.0 and 1.5 < run.sigma_hat[2, 0] < 4.0
    far = simulate_scenario(
        MODEL,
        3.0,
        Scenario(),
        horizon=1.0,
        windows=2,
        seed=2,
        extra=[imm_kbf(MODEL, sigma_range=(0.01, 0.02), modes=3)],
    )
    assert far.diverged[3] is None and np.all(np.isfinite(far.mse[:, 3]))
    assert far.sigma_hat[1, 0] == pytest.approx(0.02, rel=1e-6)


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"modes": 0}, "modes"),
        ({"switch": 1.0}, "switch"),
        ({"switch": 0.0}, "switch"),
        ({"sigma_range": (5.0, 5.0)}, "sigma_max > sigma_min"),
    ],
)
def test_bad_settings_are_named(kwargs, named):
    with pytest.raises(ValueError, match=named):
        imm_kbf(MODEL, **kwargs)


def test_the_imm_filter_runs_in_scenario_runs_only():
    with pytest.raises(ValueError, match="scenario runs only"):
        simulate(MODEL, 3.0, horizon=1.0, extra=[imm_kbf(MODEL)])
