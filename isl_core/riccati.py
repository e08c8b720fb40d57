"""Stationary Kalman–Bucy filter: the CARE, its gain, RMSE and settling rate (A.10, A.21–A.24, B.4–B.7, B.16–B.18).

    dX̂ = A X̂ dt + K (dY − C X̂ dt)                   (A.21; B.4, the filter this gain drives)
    A Δ + Δ Aᵀ + β² E Eᵀ − σ⁻² Δ Cᵀ C Δ = 0        (A.23; B.7 with Q = Δ, Σ = σ²)
    K = σ⁻² Δ Cᵀ,   s_i = √Δ_ii                       (A.21, A.29–A.30; B.5; Δ = cov(X̂ − X) is B.6's Q)
    r_min = min_i −Re λ_i(A − K C)                    (A.24)

α = 0 has a closed form through the normalized solution G = G(m) of
``A0 G + G A0ᵀ + E Eᵀ − G Cᵀ C G = 0`` (A.10, B.17):

    Δ_ij = G_ij σ² (β/σ)^{(i+j−1)/m},   K_i = G_i1 (β/σ)^{i/m}      (B.16, B.18)

The CARE is solved in normalized form, which keeps it well conditioned for every σ/β (a direct solve
fails for e.g. σ = 0.01, β = 21, α = 25): with the rate ``ϱ = (β/σ)^{1/m}`` and ``S = diag(ϱ^1 … ϱ^m)``,

    Δ = σ² ϱ⁻¹ S Δ' S,   A' Δ' + Δ' A'ᵀ + E Eᵀ − Δ' Cᵀ C Δ' = 0,   A' = A0 − (α/ϱ) E Eᵀ

(substitute: ``A S = ϱ S A'``, ``β² EEᵀ = σ² S EEᵀ S``, ``S CᵀC S = ϱ² CᵀC``). For α = 0, Δ' = G and
this is (B.16).

Domain: the normalized CARE depends on the one number ``a = α/ϱ``; its solution is accurate to ≲ 3e-12
(relative residual) up to ``a = A_MAX = 10⁵`` for every m ≤ 6 and degrades beyond (m = 2, a = 10⁷: a closed-loop
rate off by a factor 30). :func:`kalman_bucy` refuses ``a > A_MAX`` (m ≥ 2; m = 1 is scalar and exact) and any
model whose Δ, K or eigenvalues leave the float64 range, with a ``ValueError`` naming α, β, σ, m and the limit —
never a wrong number. The dashboard's ranges reach a ≤ 3.2·10⁴.

Symbols: ``delta`` = Δ, ``K`` gain (m,), ``eig`` eigenvalues of ``A − K C``, ``rho`` = ϱ.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.linalg import solve_continuous_are

from .bounds import BOUNDS
from .model import Model, shift_matrix

__all__ = ["A_MAX", "G_matrix", "KalmanBucy", "care_residual", "kalman_bucy", "kalman_bucy_alpha0", "normalized_care"]

A_MAX = 1e5  #: largest normalized damping α/ϱ (ϱ = (β/σ)^{1/m}) solved; see the module docstring


def _normalized_residual(a1: np.ndarray, d: np.ndarray) -> float:
    """Largest entry of ``A'Δ' + Δ'A'ᵀ + EEᵀ − Δ'CᵀCΔ'`` relative to the largest of its terms."""
    ad = a1 @ d
    ee = np.zeros_like(d)
    ee[-1, -1] = 1.0
    dcd = np.outer(d[:, 0], d[:, 0])
    res = ad + ad.T + ee - dcd
    return float(np.max(np.abs(res)) / max(np.max(np.abs(ad)), 1.0, np.max(np.abs(dcd))))


def _hamiltonian_care(a1: np.ndarray) -> np.ndarray:
    """Stable invariant subspace of the Hamiltonian ``[[A'ᵀ, −CᵀC], [−EEᵀ, −A']]``: Δ' = U₂U₁⁻¹."""
    m = a1.shape[0]
    h = np.zeros((2 * m, 2 * m))
    h[:m, :m] = a1.T
    h[0, m] = -1.0  # −CᵀC
    h[2 * m - 1, m - 1] = -1.0  # −EEᵀ
    h[m:, m:] = -a1
    w, v = np.linalg.eig(h)
    stable = np.argsort(w.real)[:m]
    d = np.linalg.solve(v[:m, stable].T, v[m:, stable].T).T.real
    sym: np.ndarray = 0.5 * (d + d.T)
    return sym


@lru_cache(maxsize=4096)
def normalized_care(m: int, a: float) -> np.ndarray:
    """Solution Δ' of ``A'Δ' + Δ'A'ᵀ + EEᵀ − Δ'CᵀCΔ' = 0`` with ``A' = A0 − a EEᵀ`` (A.10 when a = 0).

    The normalized CARE is well conditioned, so the eigenvectors of its 2m×2m Hamiltonian give Δ' (far cheaper
    than a Schur decomposition: :ref:`performance-choices`); if their residual or definiteness is off by more than
    ``1e3·m²·eps``, scipy's Schur solver takes over. Cached: the result is read-only.
    """
    a1 = shift_matrix(m)
    a1[-1, -1] = -a
    d = _hamiltonian_care(a1)
    tol = 1e3 * m * m * np.finfo(float).eps
    if not (np.all(np.isfinite(d)) and _normalized_residual(a1, d) < tol and np.linalg.eigvalsh(d)[0] > 0):
        e = np.zeros((m, 1))
        e[-1, 0] = 1.0
        c = np.zeros((1, m))
        c[0, 0] = 1.0
        d = solve_continuous_are(a1.T, c.T, e @ e.T, np.eye(1))
        d = 0.5 * (d + d.T)
    d.flags.writeable = False
    return d


def _G(m: int) -> np.ndarray:
    return normalized_care(m, 0.0)  # (A.10)


def G_matrix(m: int) -> np.ndarray:
    """Positive-definite solution G(m) of ``A0 G + G A0ᵀ + E Eᵀ − G Cᵀ C G = 0`` (A.10, B.17).

    Parameters
    ----------
    m : int
        State dimension.

    Returns
    -------
    numpy.ndarray
        G(m), (m, m), symmetric positive definite.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import G_matrix
    >>> G = G_matrix(3)
    >>> bool(np.allclose(G, G.T) and np.all(np.linalg.eigvalsh(G) > 0))
    True
    """
    return _G(BOUNDS.m.whole(m)).copy()


@dataclass(frozen=True)
class KalmanBucy:
    """Stationary Kalman–Bucy filter of a :class:`Model` (A.21–A.24).

    ``K`` gain (m,), ``delta`` error covariance Δ (m, m), ``s = √diag Δ``, ``eig`` eigenvalues of
    ``A − K C`` and ``r_min = min −Re eig`` (A.24).
    """

    K: np.ndarray
    delta: np.ndarray
    s: np.ndarray
    eig: np.ndarray
    r_min: float


def _result(model: Model, delta: np.ndarray, eig: np.ndarray | None = None) -> KalmanBucy:
    A, sigma = model.A, model.sigma
    delta = 0.5 * (delta + delta.T)
    K = delta[:, 0] / sigma**2  # K = σ⁻² Δ Cᵀ (A.21)
    if eig is None:
        closed = A.copy()
        closed[:, 0] -= K  # A − K C
        eig = np.linalg.eigvals(closed)
    if not (
        np.all(np.isfinite(delta))
        and np.all(np.isfinite(K))
        and np.all(np.isfinite(eig))
        and np.all(np.diagonal(delta) > 0)
        and np.min(-eig.real) > 0
    ):
        raise ValueError(
            f"alpha = {model.alpha:g}, beta = {model.beta:g}, sigma = {model.sigma:g}, m = {model.m}: the "
            "Kalman–Bucy filter's covariance or rates leave the float64 range; bring sigma/beta closer "
            "to 1"
        )
    for arr in (K, delta, eig):
        arr.flags.writeable = False
    s = np.sqrt(np.diag(delta))
    s.flags.writeable = False
    return KalmanBucy(K=K, delta=delta, s=s, eig=eig, r_min=float(np.min(-eig.real)))  # (A.24)


def kalman_bucy(model: Model) -> KalmanBucy:
    """Solve the CARE (A.23) for ``model`` and return gain, Δ, s_i and r_min (A.24).

    Cached per (frozen, hashable) model — its arrays are read-only: one dashboard run asks for it four times (the
    grid, the run, the theory, the filters). ``isl_core.clear_caches`` empties the cache.

    Parameters
    ----------
    model : Model
        The model whose continuous algebraic Riccati equation is solved.

    Returns
    -------
    KalmanBucy
        ``K`` the gain (m,), ``delta`` the stationary error covariance Δ (m, m), ``s`` the optimal RMSEs √Δ_ii,
        ``eig`` the eigenvalues of A − KC and ``r_min`` the slowest of their rates.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import Model, kalman_bucy
    >>> kb = kalman_bucy(Model.from_w(0.5, 3.0, 20.0))
    >>> kb.s.shape, bool(kb.r_min > 0)
    ((3,), True)
    >>> bool(np.allclose(kb.s, np.sqrt(np.diag(kb.delta))))
    True
    """
    if not isinstance(model, Model):
        raise ValueError(f"model must be an isl_core.Model, got {type(model).__name__}")
    return _solved(model)


@lru_cache(maxsize=1024)
def _solved(model: Model) -> KalmanBucy:
    rho = (model.beta / model.sigma) ** (1.0 / model.m)
    a = model.alpha / rho if rho > 0 else np.inf
    if model.m > 1 and not a <= A_MAX:
        raise ValueError(
            f"alpha = {model.alpha:g} with beta = {model.beta:g}, sigma = {model.sigma:g}, m = {model.m}: the "
            f"normalized damping alpha·(sigma/beta)^(1/m) = {a:.3g} is above {A_MAX:g}, beyond which the Riccati "
            "equation (A.23) is not solved to 1e-9 here; lower alpha or sigma, or raise beta"
        )
    scale = rho ** np.arange(1, model.m + 1)
    delta1 = normalized_care(model.m, a)
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        delta = model.sigma**2 / rho * scale[:, None] * delta1 * scale[None, :]  # (A.23), normalized form
        closed1 = shift_matrix(model.m)
        closed1[-1, -1] = -a
        closed1[:, 0] -= delta1[:, 0]  # A' − K'C: the closed loop in normalized time (better conditioned)
        eig = rho * np.linalg.eigvals(closed1)
    return _result(model, delta, eig)


def kalman_bucy_alpha0(m: int, beta: float, sigma: float) -> KalmanBucy:
    """Closed form for α = 0: ``Δ_ij = G_ij σ² (β/σ)^{(i+j−1)/m}`` (B.16), ``K_i = G_i1 (β/σ)^{i/m}`` (B.18).

    Parameters
    ----------
    m : int
        State dimension.
    beta, sigma : float
        The noises' intensities (> 0).

    Returns
    -------
    KalmanBucy
        As :func:`kalman_bucy` for ``Model(0, beta, sigma, m)``.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import Model, kalman_bucy, kalman_bucy_alpha0
    >>> closed = kalman_bucy_alpha0(3, 3.0, 20.0)
    >>> bool(np.allclose(closed.delta, kalman_bucy(Model(0.0, 3.0, 20.0, 3)).delta, rtol=1e-8))
    True
    """
    model = Model(0.0, beta, sigma, m)
    i = np.arange(1, model.m + 1)
    expo = (i[:, None] + i[None, :] - 1) / model.m
    delta = _G(model.m) * model.sigma**2 * (model.beta / model.sigma) ** expo  # (B.16)
    return _result(model, delta)


def care_residual(model: Model, delta: np.ndarray) -> np.ndarray:
    """Left-hand side of (A.23) at ``delta``; zero for the exact solution.

    Parameters
    ----------
    model : Model
        The model.
    delta : numpy.ndarray
        A candidate Δ (m, m).

    Returns
    -------
    numpy.ndarray
        The residual (m, m).

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import care_residual, kalman_bucy
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> delta = kalman_bucy(model).delta
    >>> bool(np.abs(care_residual(model, delta)).max() <= 1e-9 * np.abs(delta).max() ** 2)
    True
    """
    A, E, C = model.A, model.E, model.C
    res: np.ndarray = A @ delta + delta @ A.T + model.beta**2 * (E @ E.T) - delta @ C.T @ C @ delta / model.sigma**2
    return res
