"""A slow, plain-numpy twin of the compiled kernel, written straight from the equations (tests and benchmarks).

Matrix form of :ref:`simulation` on the grid t_k = k·h **in state coordinates** (the kernel integrates the errors,
:ref:`error-coordinates`: the two agree to rounding while the signal is small), noise rows ``(v_k, ε_k)`` of
``rng.standard_normal((n, 2))``
drawn in bulk right after the initial state and the filters' common start error
(``initial_state``, ``initial_error``, ``draw_noise`` of the engine, :mod:`isl_core._engine`):

    Y_{k+1} − Y_k = h·C·X_k + σ·√h·ε_k                                      (B.34)
    KBF (linear φ = K):  Ẑ_{k+1} = Ẑ_k + h·A_f·Ẑ_k + K·[Y_{k+1} − Y_k − h·C·Ẑ_k]        (B.30)
    ISL (power law):     Ž_{k+1} = (I + h·A_f)·Ž_k + √h·φ((Y_{k+1} − Y_k)/√h − √h·C·Ž_k)   (A.18, B.32)
    X_{k+1} = (I + h·A)·X_k + β·E·√h·v_k                                    (B.33)

with ``A_f = A0 − a_f·EEᵀ`` (a_f = ``spec.damp``) and φ of :func:`isl_core.nonlinearity.phi` (A.17).
Adaptive Kalman–Bucy (:mod:`isl_core.filters.adaptive`): the KBF step with the gain K(σ̂_{k−1}) read off the table by
``numpy.interp`` in log σ, then, with u_k = ΔY_k/√h − √h·Ẑ_1(t_k),

    v_k = v_{k−1} + max(1/k, 1/W)·(u_k² − v_{k−1}),    σ̂_k = √(v_k / (1 + h·K_1(σ̂_{k−1})))

No shortcuts: full matrix products, ``pow`` for every exponent, one step at a time.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ._engine import draw_noise, initial_error, initial_state
from .filters.base import FilterSpec
from .model import Model
from .nonlinearity import phi
from .riccati import kalman_bucy

__all__ = ["reference_sigma_hat", "reference_trajectories"]


def reference_trajectories(
    model: Model, filters: Sequence[FilterSpec], *, h: float, n: int, seed: int, start: str = "stationary"
) -> tuple[np.ndarray, np.ndarray]:
    """Truth ``X`` (n+1, m) and estimates ``Z`` (nf, n+1, m) of ``filters`` over ``n`` steps of size ``h``.

    Same seed, h and n as :func:`isl_core.simulate` (``run.h``, ``run.N``) → the same noise, so the two
    implementations must agree up to rounding.
    """
    X, Z, _ = reference_sigma_hat(model, filters, h=h, n=n, seed=seed, start=start)
    return X, Z


def reference_sigma_hat(
    model: Model, filters: Sequence[FilterSpec], *, h: float, n: int, seed: int, start: str = "stationary"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`reference_trajectories` plus σ̂ (nf, n+1) of the adaptive filters (nan rows for the others)."""
    m = model.m
    rng = np.random.default_rng(seed)
    x = initial_state(model, rng)
    e0 = initial_error(kalman_bucy(model), rng) if start == "stationary" else np.zeros(m)
    noise = draw_noise(rng, n)
    eye, A0, E, C = np.eye(m), model.A0, model.E, model.C
    truth_step = eye + h * model.A  # (B.33)
    A_f = [A0 - spec.damp * (E @ E.T) for spec in filters]
    X = np.empty((n + 1, m))
    Z = np.zeros((len(filters), n + 1, m))
    X[0] = x
    Z[:, 0] = x + e0  # every filter starts at X(0) − e₀ (:ref:`start`)
    S = np.full((len(filters), n + 1), np.nan)
    var = {}
    for f, spec in enumerate(filters):
        if spec.adaptive is not None:
            S[f, 0], var[f] = spec.adaptive.sigma_init, spec.adaptive.sigma_init**2
    sqh = math.sqrt(h)
    for k in range(n):
        v, eps = noise[k]
        dY = h * (C @ X[k])[0] + model.sigma * sqh * eps  # (B.34)
        for f, spec in enumerate(filters):
            z = Z[f, k]
            if spec.adaptive is not None:  # adaptive Kalman–Bucy: (B.30) with K(σ̂_k), then σ̂ takes in u
                gain = spec.adaptive.gain(S[f, k])
                Z[f, k + 1] = z + h * (A_f[f] @ z) + gain * (dY - h * (C @ z)[0])
                u = dY / sqh - sqh * (C @ z)[0]
                var[f] += max(1.0 / (k + 1), 1.0 / spec.adaptive.memory) * (u**2 - var[f])
                S[f, k + 1] = math.sqrt(var[f] / (1.0 + h * gain[0]))
            elif spec.power:  # ISL (A.18)
                u = dY / sqh - sqh * (C @ z)[0]
                Z[f, k + 1] = (eye + h * A_f[f]) @ z + sqh * phi(u, spec.coef, spec.exponents())
            else:  # Kalman–Bucy (B.30)
                Z[f, k + 1] = z + h * (A_f[f] @ z) + spec.coef * (dY - h * (C @ z)[0])
        X[k + 1] = truth_step @ X[k] + model.beta * E[:, 0] * sqh * v  # (B.33)
    return X, Z, S
