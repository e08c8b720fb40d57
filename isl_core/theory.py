"""Statistical-linearization theory of a filter's stationary error (B.40–B.48, :ref:`theory`).

Every filter of :mod:`isl_core.filters` is ``dZ = (A0 − a·EEᵀ) Z dt + φ(innovation)``. Over one Euler step
the innovation is ``u = −√h·e_1 + σε`` with ``e = Z − X``, and for small h

    √h·φ(u) ≈ −h·σ⁻² L e_1 + √h·φ(σε),   L = E[φ(ξ)ξ],  ξ ~ N(0, σ²)   (Stein: E φ'(ξ) = L/σ²)  (B.40)

so the drift of φ is linear in the error and its noise has covariance ``Φ = E[φφᵀ]`` per unit time (B.43).
With the truth ``dX = A X dt + βE dv`` and ``(A0 − aEEᵀ) Z − A X = (A0 − aEEᵀ) e + (α − a) X_m E``:

    de   = Λ e dt + (α − a)·X_m E dt − βE dv + dW_φ,     Λ = A0 − a·EEᵀ − σ⁻² L C      (B.46)
    dX_m = −α X_m dt + β dv                                                             (A.5)

with the **same** dv in both lines and the φ-noise ``dW_φ`` (covariance Φ dt) independent of dv: it is made
of the observation noise ε only. The stacked state ξ = (e, X_m) obeys ``dξ = M ξ dt + dη`` with

    M = [[Λ, (α − a)E], [0, −α]],     Q = Cov(dη)/dt = [[Φ + β²EEᵀ, −β²E], [−β²Eᵀ, β²]]

(the off-diagonal block is Cov(−βE dv, β dv)/dt), and its stationary covariance P solves the Lyapunov
equation ``M P + P Mᵀ + Q = 0``. The predicted RMSE of coordinate i is ``√P_ii``.

* a = α (a filter that propagates with the true A: the optimal or a mismatched Kalman–Bucy filter, a
  model-aware ISL filter) — the coupling vanishes and the e-block alone is (B.48):
  ``Λ Δ̌ + Δ̌ Λᵀ + β² EEᵀ + Φ = 0``; for a linear φ = K̄u this is the mismatched-gain equation
  ``(A − K̄C)P + P(A − K̄C)ᵀ + β²EEᵀ + σ²K̄K̄ᵀ = 0`` (:ref:`mismatched-kbf`).
* α = 0, a = 0 (paper B) — the same m×m equation (B.48); m = 1, ν = β gives Δ̌/Q = √(π/2) (B.52).
* α > 0, a ≠ α (paper A's ISL filter propagates with A0, a = 0) — the full (m+1)-system above.
* α = 0, a ≠ 0 — X_m is a Brownian motion that the error follows: no stationary error (ratio inf).

When Λ (or M) is not Hurwitz there is no stationary error: the prediction is ``inf``.
The prediction is accurate near the best ν; it under-predicts badly when the filter loses lock (:ref:`theory-accuracy`).

Symbols: ``spec.damp`` = a, ``L``, ``Phi`` = Φ, ``lam`` = Λ, ``P`` the (m+1) covariance.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from .filters.base import FilterSpec
from .filters.isl import isl_filter
from .filters.kalman import mismatched_kbf
from .model import Model
from .nonlinearity import gamma_moments
from .riccati import kalman_bucy
from .validate import check_real, check_reals, short

__all__ = [
    "lyapunov",
    "mismatched_kbf_ratios",
    "predicted_covariance",
    "predicted_ratios",
    "predicted_ratios_grid",
    "theory_ratios",
]


def lyapunov(M: np.ndarray, Q: np.ndarray, h: float = 0.0) -> np.ndarray:
    """Solve ``M P + P Mᵀ + h·M P Mᵀ + Q = 0`` for stacks of small matrices (..., n, n) by the Kronecker form.

    ``(I ⊗ M + M ⊗ I + h·M ⊗ M) vec P = −vec Q`` (row-major vec); n ≤ 7 here, so the n²×n² solve is cheap
    and batches. ``h = 0`` is the continuous Lyapunov equation; ``h > 0`` is the stationary covariance
    ``P = F P Fᵀ + h Q`` of the Euler recursion ``ξ_{k+1} = (I + hM) ξ_k + √h η_k``, Cov η = Q, divided by h.
    """
    M = np.asarray(M, dtype=float)
    n = M.shape[-1]
    eye = np.eye(n)
    K = np.einsum("...ik,jl->...ijkl", M, eye) + np.einsum("ik,...jl->...ijkl", eye, M)
    if h:
        K = K + h * np.einsum("...ik,...jl->...ijkl", M, M)
    K = K.reshape((*M.shape[:-2], n * n, n * n))
    q = np.broadcast_to(Q, M.shape).reshape((*M.shape[:-2], n * n, 1))
    P = np.linalg.solve(K, -q).reshape(M.shape)
    return 0.5 * (P + np.swapaxes(P, -1, -2))


def _optimal_s(model: Model) -> np.ndarray:
    """Optimal RMSE ``s_i = √Δ_ii`` (A.29–A.30)."""
    return kalman_bucy(model).s


def _moments(coef: np.ndarray, q: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Batched closed forms ``L = c γ_{1+q} σ^{1+q}``, ``Φ = c cᵀ γ_{q_i+q_j} σ^{q_i+q_j}`` (B.40, B.43).

    ``coef`` (..., m) shares the exponents ``q`` (m,).
    """
    g1, g2 = gamma_moments(tuple(float(x) for x in q))
    qq = q[:, None] + q[None, :]
    L = coef * g1 * sigma ** (1.0 + q)  # (B.40)
    Phi = coef[..., :, None] * coef[..., None, :] * g2 * sigma**qq  # (B.43)
    return L, Phi


def _stationary(model: Model, damp: float, coef: np.ndarray, q: np.ndarray, h: float = 0.0) -> np.ndarray:
    """Stationary error covariances (..., m, m) of filters with gains ``coef`` (..., m); inf if none exists."""
    m, alpha, beta, sigma = model.m, model.alpha, model.beta, model.sigma
    L, Phi = _moments(coef, q, sigma)
    lam = np.broadcast_to(model.A0, (*L.shape, m)).copy()
    lam[..., -1, -1] -= damp
    lam[..., :, 0] -= L / sigma**2  # Λ = A0 − a EEᵀ − σ⁻² L C   (B.46)
    stable = np.all(np.linalg.eigvals(lam).real < 0.0, axis=-1)
    coupled = damp != alpha
    if coupled and alpha == 0.0:
        return np.full(lam.shape, np.inf)
    n = m + 1 if coupled else m
    M = np.zeros((*L.shape[:-1], n, n))
    Q = np.zeros((*L.shape[:-1], n, n))
    M[..., :m, :m] = lam
    Q[..., :m, :m] = Phi
    Q[..., m - 1, m - 1] += beta**2  # β² EEᵀ + Φ   (B.48)
    if coupled:
        M[..., m - 1, m] = alpha - damp  # (α − a) X_m E
        M[..., m, m] = -alpha  # dX_m = −α X_m dt + β dv   (A.5)
        Q[..., m - 1, m] = Q[..., m, m - 1] = -(beta**2)  # Cov(−βE dv, β dv)
        Q[..., m, m] = beta**2
    M = np.where(stable[..., None, None], M, -np.eye(n))  # keep the solve regular; unstable ones → inf below
    P = lyapunov(M, Q, h)[..., :m, :m]
    ok = stable & np.all(np.isfinite(P), axis=(-2, -1)) & np.all(np.diagonal(P, axis1=-2, axis2=-1) > 0, axis=-1)
    return np.where(ok[..., None, None], P, np.inf)


def _check_spec(model: Model, spec: FilterSpec) -> None:
    if not isinstance(model, Model):
        raise ValueError(f"model must be an isl_core.Model, got {type(model).__name__}")
    if not isinstance(spec, FilterSpec) or len(spec.coef) != model.m:
        raise ValueError(f"spec must be a FilterSpec of size m = {model.m}, got {short(spec)}")


def predicted_covariance(model: Model, spec: FilterSpec, *, h: float | None = None) -> np.ndarray:
    """Stationary error covariance ``E[(Z − X)(Z − X)ᵀ]`` of filter ``spec`` on ``model`` (B.48,
    :ref:`linearized-covariance`).

    Solves the (m+1)-dimensional Lyapunov equation of the (e, X_m) system in the module docstring
    (m-dimensional (B.48) when ``spec.damp == model.alpha``). All entries are ``inf`` when the linearized
    filter is not stable (Λ not Hurwitz) or the error has no stationary law (α = 0 with damp ≠ 0). All
    entries are ``nan`` for an adaptive filter (``spec.adaptive``): this theory has no prediction for it.

    ``h``: the same on the Euler grid of step h (B.30–B.34) — the stationary covariance of the recursion
    ``ξ_{k+1} = (I + hM)ξ_k + √h η_k``; for a linear φ this is *exact* for the simulated scheme (its error
    obeys that recursion), and differs from the continuous answer by O(h·rate).

    Parameters
    ----------
    model : Model
        The model.
    spec : FilterSpec
        The filter.
    h : float, optional
        The Euler step, for the grid's own covariance (default: the continuous-time limit).

    Returns
    -------
    numpy.ndarray
        P (m, m).

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import kalman_bucy, optimal_kbf, predicted_covariance
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> kb = kalman_bucy(model)
    >>> bool(np.allclose(predicted_covariance(model, optimal_kbf(model, kb)), kb.delta))  # the optimal filter: Δ
    True
    """
    _check_spec(model, spec)
    if spec.adaptive is not None:
        P = np.full((model.m, model.m), np.nan)
        P.flags.writeable = False
        return P
    h = 0.0 if h is None else check_real("h", h, lo=0.0, lo_open=True)
    P = _stationary(model, float(spec.damp), np.asarray(spec.coef, dtype=float), spec.exponents(), h)
    P.flags.writeable = False
    return P


def _isl_spec(model: Model, nu: float, damp: float | None) -> FilterSpec:
    spec = isl_filter(model, nu)  # checks ν
    if damp is not None:
        spec = dataclasses.replace(spec, damp=check_real("damp", damp, lo=0.0))
    return spec


def predicted_ratios(model: Model, nu: float, *, damp: float | None = None) -> np.ndarray:
    """Predicted RMSE ratios ``š_i/s_i`` (m,) of the ISL filter with tuning ``nu`` (B.48, :ref:`linearized-covariance`).

    ``damp`` is the filter's propagation damping a: ``None`` (default) is paper A's filter with A0 (a = 0);
    ``damp=model.alpha`` is an ISL filter that propagates with the true A. ``inf`` when unstable.

    Parameters
    ----------
    model : Model
        The model.
    nu : float
        The ISL filter's tuning ν > 0.
    damp : float, optional
        The filter's propagation damping (see above).

    Returns
    -------
    numpy.ndarray
        The ratios š_i/s_i per coordinate (m,): ≥ 1, the optimal filter being 1.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import Model, predicted_ratios
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> ratios = predicted_ratios(model, model.beta)
    >>> ratios.shape, bool(np.all(ratios >= 1.0))
    ((3,), True)
    """
    spec = _isl_spec(model, nu, damp)
    s = _optimal_s(model)
    ratios: np.ndarray = np.sqrt(np.diagonal(predicted_covariance(model, spec))) / s
    return ratios


def predicted_ratios_grid(model: Model, nus: Sequence[float] | np.ndarray, *, damp: float | None = None) -> np.ndarray:
    """:func:`predicted_ratios` for many ν at once: shape (len(nus), m), one batched Lyapunov solve.

    Parameters
    ----------
    model : Model
        The model.
    nus : sequence of float
        The tunings ν > 0.
    damp : float, optional
        As in :func:`predicted_ratios`.

    Returns
    -------
    numpy.ndarray
        The ratios š_i/s_i (len(nus), m).

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import predicted_ratios, predicted_ratios_grid
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> grid = predicted_ratios_grid(model, [1.5, 3.0])
    >>> grid.shape, bool(np.allclose(grid[1], predicted_ratios(model, 3.0)))
    ((2, 3), True)
    """
    nus = check_reals("nus", nus, lo=0.0, lo_open=True)
    base = _isl_spec(model, 1.0, damp)
    m = model.m
    i = np.arange(1, m + 1)
    coef = base.coef * np.asarray(nus)[:, None] ** (i / m)  # c_i ∝ ν^{i/m}   (A.17)
    P = _stationary(model, float(base.damp), coef, base.exponents())
    ratios: np.ndarray = np.sqrt(np.diagonal(P, axis1=-2, axis2=-1)) / _optimal_s(model)
    return ratios


def mismatched_kbf_ratios(model: Model, sigma_design: float) -> np.ndarray:
    """RMSE ratios √P_ii / s_i (m,) of a Kalman–Bucy filter designed for σ̄ = ``sigma_design`` (:ref:`mismatched-kbf`).

    P solves ``(A − K̄C)P + P(A − K̄C)ᵀ + β²EEᵀ + σ²K̄K̄ᵀ = 0`` with the true σ; it equals Δ (ratio 1) when σ̄ = σ.

    Parameters
    ----------
    model : Model
        The true model.
    sigma_design : float
        The σ̄ the gain is designed for.

    Returns
    -------
    numpy.ndarray
        √P_ii / s_i (m,), ≥ 1.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import mismatched_kbf_ratios
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> bool(np.allclose(mismatched_kbf_ratios(model, model.sigma), 1.0))  # σ̄ = σ: the optimal filter
    True
    >>> bool(np.all(mismatched_kbf_ratios(model, 5.0) > 1.0))
    True
    """
    if not isinstance(model, Model):
        raise ValueError(f"model must be an isl_core.Model, got {type(model).__name__}")
    spec = mismatched_kbf(model, sigma_design)
    ratios: np.ndarray = np.sqrt(np.diagonal(predicted_covariance(model, spec))) / _optimal_s(model)
    return ratios


def theory_ratios(model: Model, spec: FilterSpec) -> np.ndarray:
    """Predicted RMSE ratios ``√P_ii / s_i`` (m,) of ``spec`` on ``model`` (table in the module docstring).

    Exact (Lyapunov) for a fixed linear gain, statistical linearization (:ref:`linearization`) for the power law;
    ``nan`` for the adaptive filter, ``inf`` where the linearized filter has no stationary error.

    Parameters
    ----------
    model : Model
        The model.
    spec : FilterSpec
        The filter.

    Returns
    -------
    numpy.ndarray
        √P_ii / s_i (m,).

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import kalman_bucy, optimal_kbf, theory_ratios
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> bool(np.allclose(theory_ratios(model, optimal_kbf(model, kalman_bucy(model))), 1.0))  # the oracle
    True
    """
    ratios: np.ndarray = np.sqrt(np.diagonal(predicted_covariance(model, spec))) / _optimal_s(model)
    return ratios
