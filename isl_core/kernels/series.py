"""The compiled loops of a recorded series (:ref:`data-filters`): every filter over readings z_k at times t_k.

Between readings each filter propagates with the exact transition of its drift over the interval Δ_k
(:mod:`isl_core.series.discretize`: ``F[index[k]]``); at a reading it takes in the reading as the sensor-interval
scenario's filters take in an increment (:mod:`isl_core.kernels.scenario`): the increment ΔY = Δ_k·z_k gives the
normalized innovation ``u = ΔY/√Δ_k − √Δ_k·Z_1 = √Δ_k·(z_k − Z_1)``, and the update ``Z_i += √Δ_k·G_i·p·r^(m−i)``
with the (p, r) of the scenario loop (:func:`isl_core.kernels.scenario.reading_pair`): the power law, the linear gain,
the adaptive gain K(σ̂) (:func:`isl_core.kernels.common.table_gain`) and its variance estimator, Huber's clip. The
variational-Bayes reading is :func:`isl_core.kernels.variational.vb_update`, the IMM mixing
:func:`isl_core.kernels.imm.imm_mix`; the Kalman filter's reading (:func:`kalman_update`) serves the filter at a given
σ, the likelihood and every IMM mode.

A missing reading (NaN) only propagates. Outputs per time k: the estimate after the reading ``est`` (N, m), the
one-step prediction of the reading ``pred`` (N,), the stated innovation variance ``svar`` (N,; NaN where the filter
states none) and diag of the stated covariance ``var`` (N, m) where the filter has one.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..filters.base import KIND_ADAPTIVE, KIND_ROBUST
from .cache import CACHE, FASTMATH, njit
from .common import AD_INV_MEMORY, AD_SIGMA, AD_VAR, table_gain
from .imm import imm_mix
from .scenario import reading_pair
from .variational import vb_update

if TYPE_CHECKING:
    from .bundles import IMMState

__all__ = ["imm_series", "kalman_series", "kalman_update", "predict", "spec_series", "vb_series"]

LOG_2PI = math.log(2.0 * math.pi)


@njit(cache=CACHE, nogil=True, fastmath=FASTMATH, inline="always")
def predict(x: np.ndarray, P: np.ndarray, F: np.ndarray, Q: np.ndarray, tmp: np.ndarray) -> None:
    """x ← F x, P ← F P Fᵀ + Q in place (``tmp`` (m, m) scratch; P's leading m×m block)."""
    m = x.shape[0]
    for i in range(m):
        tmp[0, i] = x[i]
    for i in range(m):
        s = 0.0
        for j in range(m):
            s += F[i, j] * tmp[0, j]
        x[i] = s
    for i in range(m):  # tmp = F P
        for j in range(m):
            s = 0.0
            for k in range(m):
                s += F[i, k] * P[k, j]
            tmp[i, j] = s
    for i in range(m):  # P = tmp Fᵀ + Q, symmetric by construction
        for j in range(i, m):
            s = Q[i, j]
            for k in range(m):
                s += tmp[i, k] * F[j, k]
            P[i, j] = s
            P[j, i] = s


@njit(cache=CACHE, nogil=True, fastmath=FASTMATH, inline="always")
def kalman_update(x: np.ndarray, P: np.ndarray, v: float, s: float) -> None:
    """A reading of innovation v and variance s = P₁₁ + R: x += P Cᵀ v/s, P ← P − P Cᵀ C P/s, in place."""
    m = x.shape[0]
    for i in range(m):
        x[i] += P[i, 0] * v / s
    for i in range(m - 1, -1, -1):  # column 0 last: every other entry reads it before it changes
        for j in range(m - 1, i - 1, -1):
            p = P[i, j] - P[i, 0] * P[j, 0] / s
            P[i, j] = p
            P[j, i] = p


@njit(cache=CACHE, nogil=True, fastmath=FASTMATH)
def kalman_series(
    z: np.ndarray,
    index: np.ndarray,
    F: np.ndarray,
    Q: np.ndarray,
    R: float,
    x: np.ndarray,
    P: np.ndarray,
    burn: int,
    est: np.ndarray,
    var: np.ndarray,
    pred: np.ndarray,
    svar: np.ndarray,
    store: bool,
) -> float:
    """The Kalman filter of reading variance ``R`` over the series from (``x``, ``P``) at the first time; returns the
    log-likelihood of the readings after the first ``burn`` present ones (those add −½ log 2π each: the diffuse
    start's convention, :ref:`data-fit`). Writes the outputs (module docstring) when ``store``."""
    m = x.shape[0]
    tmp = np.empty((m, m))
    ll = 0.0
    seen = 0
    for k in range(z.shape[0]):
        if k > 0:
            predict(x, P, F[index[k]], Q[index[k]], tmp)
        s = P[0, 0] + R
        if store:
            pred[k] = x[0]
            svar[k] = s
        if math.isfinite(z[k]):
            v = z[k] - x[0]
            ll += -0.5 * LOG_2PI if seen < burn else -0.5 * (LOG_2PI + math.log(s) + v * v / s)
            seen += 1
            kalman_update(x, P, v, s)
        if store:
            for i in range(m):
                est[k, i] = x[i]
                var[k, i] = P[i, i]
    return ll


@njit(cache=CACHE, nogil=True, fastmath=FASTMATH)
def spec_series(
    z: np.ndarray,
    index: np.ndarray,
    sqd: np.ndarray,
    F: np.ndarray,
    kind: int,
    coef: np.ndarray,
    table: np.ndarray,
    ad: np.ndarray,
    par: np.ndarray,
    k0: int,
    est: np.ndarray,
    pred: np.ndarray,
    svar: np.ndarray,
) -> None:
    """One filter of the fused kernel's kinds — linear, power law, adaptive, robust (``kind``) — over the series
    from its start ``est[k0]`` at time k0 (the rows after it written); ``ad`` (1, AD_WIDTH) its σ-learner's state,
    ``par`` = (c, κ(c)) for the robust one."""
    m = est.shape[1]
    x = est[k0].copy()
    tmp = np.empty(m)
    gain = np.zeros((1, m))
    gain[0] = coef
    learn = (kind == KIND_ADAPTIVE) | (kind == KIND_ROBUST)
    readings = 0
    for k in range(k0 + 1, z.shape[0]):
        Fk = F[index[k]]
        for i in range(m):
            tmp[i] = x[i]
        for i in range(m):
            s = 0.0
            for j in range(m):
                s += Fk[i, j] * tmp[j]
            x[i] = s
        pred[k] = x[0]
        dt = sqd[k] * sqd[k]
        if learn:
            svar[k] = ad[0, AD_VAR] / dt
            table_gain(table, ad, 0, gain, 1.0)
        if math.isfinite(z[k]):
            readings += 1
            u = sqd[k] * (z[k] - x[0])
            lim = par[0] * ad[0, AD_SIGMA]
            p, r = reading_pair(kind, u, u, 1.0, u, lim, m)
            for i in range(m - 1, -1, -1):
                x[i] += sqd[k] * gain[0, i] * p
                p *= r
            if learn:
                uu = u * u
                if kind == KIND_ROBUST:
                    uu = min(uu, lim * lim) / par[1]
                v = ad[0, AD_VAR]
                v += max(1.0 / readings, ad[0, AD_INV_MEMORY]) * (uu - v)
                ad[0, AD_VAR] = v
                ad[0, AD_SIGMA] = math.sqrt(v / (1.0 + dt * gain[0, 0]))
        est[k] = x


@njit(cache=CACHE, nogil=True, fastmath=FASTMATH)
def vb_series(
    z: np.ndarray,
    index: np.ndarray,
    sqd: np.ndarray,
    F: np.ndarray,
    Q: np.ndarray,
    P: np.ndarray,
    ab: np.ndarray,
    par: np.ndarray,
    k0: int,
    est: np.ndarray,
    var: np.ndarray,
    pred: np.ndarray,
    svar: np.ndarray,
) -> None:
    """The variational-Bayes filter (``P`` its covariance, ``ab`` its inverse-gamma (a, b), ``par`` (ρ, iterations))
    over the series from its start ``est[k0]``; its reading is :func:`isl_core.kernels.variational.vb_update` on the
    normalized innovation, with no Euler step after it (h = 0)."""
    m = est.shape[1]
    x = est[k0].copy()
    tmp = np.empty((m, m))
    gvec = np.zeros(m)
    for i in range(m):
        var[k0, i] = P[i, i]
    for k in range(k0 + 1, z.shape[0]):
        predict(x, P, F[index[k]], Q[index[k]], tmp)
        dt = sqd[k] * sqd[k]
        pred[k] = x[0]
        svar[k] = P[0, 0] + par[0] * ab[1] / (par[0] * ab[0] + 0.5) / dt
        if math.isfinite(z[k]):
            u = sqd[k] * (z[k] - x[0])
            vb_update(P, ab, par, u, sqd[k], 0.0, 0.0, gvec)
            for i in range(m):
                x[i] += gvec[i] * u
        for i in range(m):
            est[k, i] = x[i]
            var[k, i] = P[i, i]


@njit(cache=CACHE, nogil=True, fastmath=FASTMATH)
def imm_series(
    z: np.ndarray,
    index: np.ndarray,
    sqd: np.ndarray,
    F: np.ndarray,
    Q: np.ndarray,
    bank: IMMState,
    k0: int,
    est: np.ndarray,
    var: np.ndarray,
    pred: np.ndarray,
    svar: np.ndarray,
    lpd: np.ndarray,
) -> None:
    """The IMM filter (``bank``: :func:`isl_core.kernels.imm.imm_state`'s, one bank, ``e`` its modes' states) over the
    series from time k0: each mode an exact Kalman filter of reading variance σ_j²/Δ_k, weighted by its likelihood,
    then mixed (:func:`isl_core.kernels.imm.imm_mix`). ``lpd`` (N,) the predictive log-density of each reading (the
    mixture's)."""
    P, e, mu, sig, lw, mean = bank.P, bank.e, bank.mu, bank.sigma, bank.lw, bank.mean
    J = int(bank.par[0, 1])
    m = e.shape[2]
    tmp = np.empty((m, m))
    for k in range(k0 + 1, z.shape[0]):
        dt = sqd[k] * sqd[k]
        zhat = 0.0
        for j in range(J):
            predict(e[0, j], P[0, j], F[index[k]], Q[index[k]], tmp)
            zhat += mu[0, j] * e[0, j, 0]
        spread = 0.0
        least = math.inf
        for j in range(J):
            s = P[0, j, 0, 0] + sig[0, j] ** 2 / dt
            spread += mu[0, j] * (s + (e[0, j, 0] - zhat) ** 2)
            v = z[k] - e[0, j, 0]
            lw[j] = 0.5 * (math.log(s) + v * v / s)
            least = min(least, lw[j])
        pred[k], svar[k] = zhat, spread
        if math.isfinite(z[k]):
            total = 0.0
            for j in range(J):
                s = P[0, j, 0, 0] + sig[0, j] ** 2 / dt
                kalman_update(e[0, j], P[0, j], z[k] - e[0, j, 0], s)
                lw[j] = mu[0, j] * math.exp(least - lw[j])
                total += lw[j]
            lpd[k] = math.log(total) - least - 0.5 * LOG_2PI
            for j in range(J):
                mu[0, j] = lw[j] / total
        for i in range(m):
            mean[i] = 0.0
            for j in range(J):
                mean[i] += mu[0, j] * e[0, j, i]
        for i in range(m):
            est[k, i] = mean[i]
            s2 = 0.0
            for j in range(J):
                s2 += mu[0, j] * (P[0, j, i, i] + (e[0, j, i] - mean[i]) ** 2)
            var[k, i] = s2
        if J > 1 and math.isfinite(z[k]):
            imm_mix(bank, 0, bank.par[0, 0], J)
