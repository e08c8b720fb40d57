"""A slow, plain-numpy twin of the compiled kernel, written straight from the equations (tests and benchmarks).

Matrix form of SPEC §4 on the grid t_k = k·h, noise rows ``(v_k, ε_k)`` of ``rng.standard_normal((n, 2))``
drawn in bulk right after the initial state (:func:`isl_core.simulate.initial_state`, ``draw_noise``):

    Y_{k+1} − Y_k = h·C·X_k + σ·√h·ε_k                                      (B.34)
    KBF (linear φ = K):  Ẑ_{k+1} = Ẑ_k + h·A_f·Ẑ_k + K·[Y_{k+1} − Y_k − h·C·Ẑ_k]        (B.30)
    ISL (power law):     Ž_{k+1} = (I + h·A_f)·Ž_k + √h·φ((Y_{k+1} − Y_k)/√h − √h·C·Ž_k)   (A.18, B.32)
    X_{k+1} = (I + h·A)·X_k + β·E·√h·v_k                                    (B.33)

with ``A_f = A0 − a_f·EEᵀ`` (a_f = ``spec.damp``) and φ of :func:`isl_core.nonlinearity.phi` (A.17).
No shortcuts: full matrix products, ``pow`` for every exponent, one step at a time.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .filters import FilterSpec
from .model import Model
from .nonlinearity import phi
from .simulate import draw_noise, initial_state

__all__ = ["reference_trajectories"]


def reference_trajectories(
    model: Model, filters: Sequence[FilterSpec], *, h: float, n: int, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    """Truth ``X`` (n+1, m) and estimates ``Z`` (nf, n+1, m) of ``filters`` over ``n`` steps of size ``h``.

    Same seed, h and n as :func:`isl_core.simulate` (``run.h``, ``run.N``) → the same noise, so the two
    implementations must agree up to rounding.
    """
    m = model.m
    rng = np.random.default_rng(seed)
    x = initial_state(model, rng)
    noise = draw_noise(rng, n)
    I, A0, E, C = np.eye(m), model.A0, model.E, model.C
    truth_step = I + h * model.A  # (B.33)
    A_f = [A0 - spec.damp * (E @ E.T) for spec in filters]
    X = np.empty((n + 1, m))
    Z = np.zeros((len(filters), n + 1, m))
    X[0] = x
    sqh = math.sqrt(h)
    for k in range(n):
        v, eps = noise[k]
        dY = h * (C @ X[k])[0] + model.sigma * sqh * eps  # (B.34)
        for f, spec in enumerate(filters):
            z = Z[f, k]
            if spec.power:  # ISL (A.18)
                u = dY / sqh - sqh * (C @ z)[0]
                Z[f, k + 1] = (I + h * A_f[f]) @ z + sqh * phi(u, spec.coef, spec.exponents())
            else:  # Kalman–Bucy (B.30)
                Z[f, k + 1] = z + h * (A_f[f] @ z) + spec.coef * (dY - h * (C @ z)[0])
        X[k + 1] = truth_step @ X[k] + model.beta * E[:, 0] * sqh * v  # (B.33)
    return X, Z
