"""The Kalman–Bucy filters of the stationary CARE (A.21–A.23): optimal (knows σ), mismatched and minimax (designed
for a guessed σ̄).

    Ẑ ← (I + h·A)·Ẑ + K̄·(ΔY − h·C·Ẑ),    K̄ = σ̄⁻² Δ̄ Cᵀ,  Δ̄ the CARE's solution at σ̄          (B.30, A.21–A.23)

With σ̄ = σ the gain is the optimal K (:func:`optimal_kbf`); otherwise the filter is *mismatched*
(:func:`mismatched_kbf`), its stationary error the exact Lyapunov solution of
:func:`isl_core.theory.predicted_covariance` (:ref:`mismatched-kbf`). The geometric middle of a σ range is the default
guess (:func:`design_sigma`); "assume the largest noise" is :func:`minimax_kbf`. Every one propagates with the true A
(damp = α).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..model import Model
from ..riccati import KalmanBucy, kalman_bucy
from ..validate import check_real, check_sigma_range
from .base import FilterSpec

__all__ = ["design_sigma", "minimax_kbf", "mismatched_kbf", "optimal_kbf"]


def optimal_kbf(model: Model, kb: KalmanBucy) -> FilterSpec:
    """The stationary Kalman–Bucy filter (A.21) with the true σ: linear gain K, propagation with A.

    Parameters
    ----------
    model : Model
        The model, σ included.
    kb : KalmanBucy
        Its stationary solution, :func:`isl_core.kalman_bucy` (``model``).

    Returns
    -------
    FilterSpec
        The oracle filter, named ``"kbf"``.

    Examples
    --------
    >>> from isl_core import Model, kalman_bucy, optimal_kbf
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> optimal_kbf(model, kalman_bucy(model)).name
    'kbf'
    """
    return FilterSpec("kbf", "Kalman–Bucy (optimal, knows σ)", model.alpha, np.array(kb.K, dtype=float), False)


def mismatched_kbf(model: Model, sigma_design: float) -> FilterSpec:
    """Kalman–Bucy filter whose gain K̄ solves the CARE (A.23) for σ̄ = ``sigma_design`` instead of σ.

    Parameters
    ----------
    model : Model
        The true model.
    sigma_design : float
        The σ̄ > 0 the gain is designed for.

    Returns
    -------
    FilterSpec
        The filter, named ``"kbf_mismatched"``.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import kalman_bucy, mismatched_kbf, optimal_kbf
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> mismatched_kbf(model, 5.0).name
    'kbf_mismatched'
    >>> bool(np.allclose(mismatched_kbf(model, model.sigma).coef, optimal_kbf(model, kalman_bucy(model)).coef))
    True
    """
    sigma_design = check_real("sigma_design", sigma_design, lo=0.0, lo_open=True)
    design = Model(model.alpha, model.beta, sigma_design, model.m)
    K = np.array(kalman_bucy(design).K, dtype=float)
    return FilterSpec("kbf_mismatched", f"Kalman–Bucy designed for σ̄ = {sigma_design:.4g}", model.alpha, K, False)


def design_sigma(sigma_range: tuple[float, float]) -> float:
    """The mismatched filter's default guess: the geometric middle ``√(σ_min σ_max)`` of the range."""
    lo, hi = check_sigma_range(sigma_range)
    return math.sqrt(lo * hi)


def minimax_kbf(model: Model, sigma_range: tuple[float, float]) -> FilterSpec:
    """Kalman–Bucy filter designed for the top of the σ range, σ̄ = σ_max (module docstring)."""
    _, hi = check_sigma_range(sigma_range)
    return dataclasses.replace(
        mismatched_kbf(model, hi), name="kbf_minimax", label=f"Kalman–Bucy for the largest σ (σ̄ = {hi:.4g})"
    )
