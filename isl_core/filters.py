"""Filters as interchangeable parts of one fused simulation (B.30, B.32, A.18).

Every filter here has the form (on the grid t_k = k·h, innovation u_k = ΔY_k/√h − √h·Z_1(t_k))

    Z(t_{k+1}) = (I + h·(A0 − a·E Eᵀ))·Z(t_k) + √h·φ(u_k)

with a propagation damping ``a`` (0 → A0 as in paper A's ISL filter; α → the true A) and φ either
linear, ``φ(u) = K u`` (then the step is the Kalman–Bucy scheme B.30), or the power law of (A.17),
``φ_i(u) = c_i sign(u)|u|^{1−i/m}`` (the ISL scheme A.18).

Symbols: ``damp`` = a, ``coef`` = K or c, ``power`` selects the power law.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import Model
from .nonlinearity import isl_exponents, isl_gains, linearization
from .riccati import KalmanBucy

__all__ = ["FilterSpec", "isl_filter", "linearized_matrix", "optimal_kbf"]


@dataclass(frozen=True)
class FilterSpec:
    """One filter of the fused kernel: ``Z ← (I + h(A0 − damp·EEᵀ))Z + √h φ(u)`` (B.30 / A.18)."""

    name: str
    label: str
    damp: float
    coef: np.ndarray
    power: bool

    def exponents(self) -> np.ndarray:
        """Exponents q_i of φ: all 1 for a linear gain, ``1 − i/m`` for the power law (A.17)."""
        m = len(self.coef)
        return isl_exponents(m) if self.power else np.ones(m)


def optimal_kbf(model: Model, kb: KalmanBucy) -> FilterSpec:
    """The stationary Kalman–Bucy filter (A.21) with the true σ: linear gain K, propagation with A."""
    return FilterSpec("kbf", "Kalman–Bucy (optimal, knows σ)", model.alpha, np.array(kb.K, dtype=float), False)


def isl_filter(model: Model, nu: float) -> FilterSpec:
    """Paper A's ISL filter (A.16–A.18): power-law φ tuned by ν, propagation with A0."""
    coef = isl_gains(model.m, nu)  # validates nu
    return FilterSpec("isl", f"ISL (ν = {float(nu):.4g})", 0.0, coef, True)


def linearized_matrix(model: Model, spec: FilterSpec) -> np.ndarray:
    """``Λ = A0 − a·EEᵀ − σ⁻² L C`` of the statistically linearized filter (B.46), true σ of ``model``."""
    L, _ = linearization(spec.coef, spec.exponents(), model.sigma)
    lam = model.A0
    lam[-1, -1] -= spec.damp
    lam[:, 0] -= L / model.sigma**2  # (B.46)
    return lam
