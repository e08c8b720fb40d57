"""The IMM filter's bank, compiled: one step of every mode, the mixing and the weights (Blom & Bar-Shalom 1988).

The filter, its equations and its error coordinates are :mod:`isl_core.filters.imm`'s; here is :func:`imm_step`,
which the scenario loop runs in line for every IMM filter (:mod:`isl_core.kernels.scenario`), and
:func:`imm_state`, the banks' state for that loop.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..filters.base import FilterSpec
from .bundles import IMMState
from .cache import CACHE, FASTMATH, njit
from .common import predict_cov

__all__ = ["imm_mix", "imm_state", "imm_step"]


def imm_state(filters: Sequence[FilterSpec], m: int, q: int, h: float) -> IMMState:
    """The IMM banks' state for the scenario loop (:class:`~isl_core.kernels.bundles.IMMState`), one bank per IMM
    filter of ``filters``, at the start of a sensor interval of ``q`` steps of ``h``: every mode at the stationary
    covariance of its σ_j, weights 1/J, its errors ``e`` (b, J, m) to be filled with the run's start; scratch ``V``
    and ``out`` are (J, m + m(m+1)/2) padded to a multiple of 4. Padded to the largest J (μ = 0 there)."""
    banks = [f.imm for f in filters if f.imm is not None]
    nb, jm = len(banks), max([1] + [len(b.sigmas) for b in banks])
    slot = np.full(len(filters), -1, dtype=np.int64)
    P, mu = np.zeros((nb, jm, m + 1, m + 1)), np.zeros((nb, jm))
    R, par, sig = np.ones((nb, jm)), np.zeros((nb, 2)), np.ones((nb, jm))
    b = 0
    for f, spec in enumerate(filters):
        if spec.imm is None:
            continue
        slot[f] = b
        J = len(spec.imm.sigmas)
        P[b, :J, :m, :m] = spec.imm.cov
        mu[b, :J] = 1.0 / J
        R[b, :J] = q * h * spec.imm.sigmas**2
        sig[b, :J] = spec.imm.sigmas
        par[b] = spec.imm.switch, J
        b += 1
    nv = 4 * -(-(m + m * (m + 1) // 2) // 4)  # d_i and the upper triangle, padded to a multiple of 4 (imm_mix)
    return IMMState(
        slot,
        P,
        np.zeros((nb, jm, m)),
        np.zeros((nb, jm)),
        mu,
        R,
        par,
        sig,
        np.zeros((jm, jm)),
        np.zeros((jm, nv)),
        np.zeros((jm, nv)),
        np.zeros(jm),
        np.zeros(m),
    )


@njit(cache=CACHE, nogil=True, fastmath=FASTMATH, inline="always")
def _update(P: np.ndarray, e: np.ndarray, r: float, s: float) -> None:
    """One mode's reading in place: e += P C_aᵀ r / s, P ← P − P C_aᵀ C_a P / s, then S restarts at 0 (known)."""
    a = P.shape[0]
    m = a - 1
    for i in range(m):
        e[i] += P[i, m] / s * r
    for i in range(m):
        for c in range(m):
            P[i, c] -= P[i, m] * P[c, m] / s
    for i in range(a):
        P[m, i] = 0.0
        P[i, m] = 0.0


@njit(cache=CACHE, nogil=True, fastmath=FASTMATH, inline="always")
def imm_mix(bank: IMMState, b: int, p: float, J: int) -> None:
    """Mixing (module docstring) of bank ``b`` of ``bank`` (:class:`~isl_core.kernels.bundles.IMMState`) in place:
    μ ← c̄, e_j ← e0_j, P_j ← P0_j on the X block (S is 0 after a reading), with its scratch ``mean``, ``W``, ``V``
    and ``out``.

    With d_i = e_i − ē (ē = ``mean``, the filter's error) and the weights W_ji = p_ij μ_i / c̄_j (Σ_i W_ji = 1):
    e0_j = ē + δ_j, δ_j = Σ_i W_ji d_i, and P0_j = Σ_i W_ji (P_i + d_i d_iᵀ) − δ_j δ_jᵀ — the paper's
    Σ_i W_ji [P_i + (e_i − e0_j)(e_i − e0_j)ᵀ] expanded about ē: one product of W with the rows
    V_i = (d_i, upper triangle of P_i + d_i d_iᵀ) instead of two passes, and no common part of the errors in the
    products (no cancellation when all are large).
    """
    P, e, mu, mean, W, V, out = bank.P, bank.e, bank.mu, bank.mean, bank.W, bank.V, bank.out
    m = e.shape[2]
    nv = V.shape[1]  # a multiple of 4
    stay, move = 1.0 - p, p / (J - 1)
    for j in range(J):
        inv = 1.0 / (stay * mu[b, j] + move * (1.0 - mu[b, j]))  # 1/c̄_j, c̄_j = Σ_i p_ij μ_i (Σ_i μ_i = 1)
        for i in range(J):
            W[j, i] = (stay if i == j else move) * mu[b, i] * inv
    for i in range(J):
        for k in range(m):
            V[i, k] = e[b, i, k] - mean[k]
        c = m
        for k in range(m):
            for k2 in range(k, m):
                V[i, c] = P[b, i, k, k2] + V[i, k] * V[i, k2]
                c += 1
    for j in range(J):  # out = W·V, four columns at a time in registers (V is padded with zero columns)
        for c in range(0, nv, 4):
            s0, s1, s2, s3 = 0.0, 0.0, 0.0, 0.0
            for i in range(J):
                w = W[j, i]
                s0 += w * V[i, c]
                s1 += w * V[i, c + 1]
                s2 += w * V[i, c + 2]
                s3 += w * V[i, c + 3]
            out[j, c], out[j, c + 1], out[j, c + 2], out[j, c + 3] = s0, s1, s2, s3
    for j in range(J):
        mu[b, j] = stay * mu[b, j] + move * (1.0 - mu[b, j])  # c̄_j: the next reading's prior weights
        c = m
        for k in range(m):
            e[b, j, k] = mean[k] + out[j, k]
            for k2 in range(k, m):
                P[b, j, k, k2] = out[j, c] - out[j, k] * out[j, k2]
                P[b, j, k2, k] = P[b, j, k, k2]
                c += 1


@njit(cache=CACHE, nogil=True, fastmath=FASTMATH, inline="always")
def imm_step(
    bank: IMMState,
    b: int,
    el: np.ndarray,
    f: int,
    noise: float,
    sqh: float,
    h: float,
    decay: float,
    q_var: float,
    shock: float,
    reading: bool,
    corr: np.ndarray,
) -> float:
    """Step k → k+1 of bank ``b`` of ``bank`` (module docstring), in place; returns σ̂ = Σ μ_j σ_j after a reading,
    else −1.

    Per bank (first index b of :class:`~isl_core.kernels.bundles.IMMState`, :func:`imm_state`): ``P`` (J, m+1,
    m+1), ``e`` (J, m), ``a`` (J,) the modes' covariances on (X, S), errors and innovations summed since the last
    reading, ``mu`` (J,) the weights (c̄ between readings), ``R`` (J,) q·h·σ_j², ``par`` = (p, J); ``W``, ``V``,
    ``out``, ``lw``, ``mean`` scratch (:func:`imm_mix`); ``noise`` = σ_k ε_k and ``shock`` = β√h v_k of this step. At a
    reading ``corr`` (m,) gets what the scenario loop adds to the filter's propagated error ``el[:, f]`` (at t_k on
    entry) to make it Σ_j μ_j e_j: the lane of the filter propagates it as the modes (A_f = A), and takes in ``corr`` as
    its update.
    """
    P, e, a, mu, R, par = bank.P, bank.e, bank.a, bank.mu, bank.R, bank.par
    sig, lw, mean = bank.sigma, bank.lw, bank.mean
    J = int(par[b, 1])
    m = e.shape[2]
    for j in range(J):
        a[b, j] += noise - sqh * e[b, j, 0]  # the innovation uses e at t_k, before it moves
        for i in range(m - 1):
            e[b, j, i] += h * e[b, j, i + 1]
        e[b, j, m - 1] = decay * e[b, j, m - 1] - shock
        predict_cov(P[b, j], h, decay, q_var)  # a view: inlined, it costs no call
    if not reading:
        return -1.0
    least = math.inf
    for j in range(J):  # c̄_j N(r_j; 0, s_j) ∝ c̄_j/√s_j · exp(−r_j²/(2 s_j)); the modes take in their reading
        r = sqh * a[b, j]
        s = P[b, j, m, m] + R[b, j]
        lw[j] = 0.5 * r * r / s
        least = min(least, lw[j])
        a[b, j] = mu[b, j] / math.sqrt(s)  # a_j restarts at 0 below: it holds c̄_j/√s_j until then
        _update(P[b, j], e[b, j], r, s)
    total = 0.0
    for j in range(J):  # exponents shifted by the smallest (log-sum-exp): that mode's is exp(0), none underflows all
        lw[j] = a[b, j] * math.exp(least - lw[j])
        a[b, j] = 0.0
        total += lw[j]
    sigma_hat = 0.0
    for i in range(m):
        mean[i] = 0.0
    for j in range(J):
        mu[b, j] = lw[j] / total
        sigma_hat += mu[b, j] * sig[b, j]
        for i in range(m):
            mean[i] += mu[b, j] * e[b, j, i]
    for i in range(m - 1):  # the filter's error minus the lane's propagation of el (the same arithmetic)
        corr[i] = mean[i] - (el[i, f] + h * el[i + 1, f])
    corr[m - 1] = mean[m - 1] - (decay * el[m - 1, f] - shock)
    if J > 1:
        imm_mix(bank, b, par[b, 0], J)
    return sigma_hat
