"""The variational-Bayes adaptive Kalman filter: the compiled loop equals Särkkä & Nummenmaa's Algorithm 1 written
out."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isl_core import Model, adaptive_kbf, kalman_bucy
from isl_core._engine import draw_start
from isl_core.filters.robust import robust_kbf
from isl_core.filters.variational import variational_kbf
from isl_core.scenario import Scenario, sigma_path
from isl_core.scenario.run import simulate_scenario

MODEL = Model.from_w(alpha=0.5, w=3.0, sigma=20.0, m=3)  # paper A's Fig. 3


def _vb_loop(model, spec, scenario, h, n, seed, q):
    """The variational-Bayes filter as Särkkä & Nummenmaa's Algorithm 1 in state coordinates (X̂, P, a, b), on the
    Euler truth X and the readings y = ΔY/√(qh): errors X̂ − X squared and summed."""
    kb = kalman_bucy(model)
    rng = np.random.default_rng(seed)
    x, e0 = draw_start(model, kb, rng, "stationary")
    X = np.zeros(model.m)
    X[-1] = x[-1]
    Xh = X + e0
    v = spec.variational
    P = np.array(kalman_bucy(Model(model.alpha, model.beta, v.sigma_init, model.m)).delta)
    a, b = v.shape0, v.shape0 * v.sigma_init**2
    rho = 1.0 - 1.0 / v.memory  # per reading
    F = np.eye(model.m) + h * model.A
    Q = h * model.beta**2 * (model.E @ model.E.T)
    H = math.sqrt(q * h) * model.C
    sig = sigma_path(scenario, model, kb.r_min, h, n)
    dY, pred, sq = 0.0, 0.0, np.zeros(model.m)
    for k in range(n):
        w = rng.standard_normal()
        eps = rng.standard_normal()
        dY += h * X[0] + sig[k] * math.sqrt(h) * eps
        pred += h * Xh[0]
        if (k + 1) % q == 0:  # y − H X̂⁻ = (ΔY − predicted increment)/√(qh)
            u = (dY - pred) / math.sqrt(q * h)
            a_pr, b_pr = rho * a, rho * b
            a, b = a_pr + 0.5, b_pr
            for _ in range(v.iterations):
                S = (H @ P @ H.T).item() + b / a
                K = P @ H.T / S
                post, Ppost = Xh + K[:, 0] * u, P - K @ K.T * S
                b = b_pr + 0.5 * (u - (H @ (post - Xh)).item()) ** 2 + 0.5 * (H @ Ppost @ H.T).item()
            Xh, P = post, Ppost
            dY, pred = 0.0, 0.0
        Xh = F @ Xh
        P = F @ P @ F.T + Q
        X = F @ X
        X[-1] += model.beta * math.sqrt(h) * w
        sq += (Xh - X) ** 2
    return sq


@pytest.mark.parametrize("before", [0, 2])  # the filters run in lanes of four: the VB filter in the first or second
@pytest.mark.parametrize("scenario", [Scenario(sigma_knots=((0.2, 2.0),)), Scenario(sensor_interval=0.03)])
def test_the_compiled_variational_filter_equals_the_papers_algorithm(scenario, before):
    spec = variational_kbf(MODEL, sigma_init=60.0, memory=200.0)
    extra = [*[adaptive_kbf(MODEL), robust_kbf(MODEL)][:before], spec]
    run = simulate_scenario(MODEL, 3.0, scenario, horizon=0.6, windows=5, seed=9, extra=extra)
    sq = _vb_loop(MODEL, spec, scenario, run.h, run.N, 9, run.q)
    got = np.tensordot(run.steps.astype(float), run.mse, axes=1)[3 + before]
    assert np.allclose(got, sq, rtol=1e-10, atol=0.0)  # agrees to ≈ 1e-15 (measured)
    assert run.sigma_hat.shape == (5, 1 + before) and np.all(np.isfinite(run.sigma_hat))
