"""The variational-Bayes filter's steps, compiled: its covariance's prediction and its reading (Särkkä & Nummenmaa
2009), which the scenario loop runs in line (:mod:`isl_core.kernels.scenario`). The filter and its equations are
:mod:`isl_core.filters.variational`'s.
"""

from __future__ import annotations

import numpy as np

from .cache import CACHE, njit

__all__ = ["predict_cov", "vb_update"]


@njit(cache=CACHE, nogil=True)
def predict_cov(P: np.ndarray, h: float, a: float, q_var: float) -> None:
    """P ← F P Fᵀ + q_var·E Eᵀ, F = I + h·(A0 − a·E Eᵀ), in place (F is bidiagonal: O(m²))."""
    m = P.shape[0]
    for j in range(m):  # rows: F P
        for i in range(m - 1):
            P[i, j] += h * P[i + 1, j]
        P[m - 1, j] *= 1.0 - h * a
    for i in range(m):  # columns: (F P) Fᵀ
        for j in range(m - 1):
            P[i, j] += h * P[i, j + 1]
        P[i, m - 1] *= 1.0 - h * a
    P[m - 1, m - 1] += q_var


@njit(cache=CACHE, nogil=True)
def vb_update(
    P: np.ndarray, ab: np.ndarray, par: np.ndarray, u: float, H: float, h: float, a_f: float, gvec: np.ndarray
) -> float:
    """One reading of the variational-Bayes filter: updates P and (a, b) in place, writes F·K into ``gvec``;
    returns σ̂ = √(b/a)."""
    m = P.shape[0]
    a = par[0] * ab[0] + 0.5  # a⁻ = ρa, b⁻ = ρb: ρ per reading
    b_pr = par[0] * ab[1]
    b = b_pr
    p11 = P[0, 0]
    k1 = 0.0
    s = 1.0
    for _ in range(int(par[1])):
        s = H * H * p11 + b / a
        k1 = P[0, 0] * H / s
        resid = u * (1.0 - H * k1)
        b = b_pr + 0.5 * resid * resid + 0.5 * H * H * (p11 - k1 * s * k1)
    for i in range(m):
        gvec[i] = P[i, 0] * H / s
    for i in range(m):
        for j in range(m):
            P[i, j] -= gvec[i] * s * gvec[j]
    for i in range(m - 1):  # F·K
        gvec[i] += h * gvec[i + 1]
    gvec[m - 1] *= 1.0 - h * a_f
    ab[0], ab[1] = a, b
    return float(np.sqrt(b / a))
