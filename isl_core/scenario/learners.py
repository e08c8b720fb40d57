"""The σ-learning filters of a scenario run at their start: which filters learn σ, and the state the variational,
robust and IMM filters begin from (:ref:`variational-kbf`, :ref:`robust-kbf`, :ref:`imm`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np

from ..filters.base import KIND_ADAPTIVE, KIND_IMM, KIND_ROBUST, KIND_VB, FilterSpec
from ..filters.robust import huber_kappa
from ..kernels.common import AD_SIGMA
from ..model import Model
from ..riccati import kalman_bucy

__all__ = ["learning_state", "learns_sigma"]


def learns_sigma(kind: np.ndarray) -> np.ndarray:
    """Which filters learn σ (and have a σ̂ column): the adaptive, variational, robust and IMM filters."""
    return cast("np.ndarray", (kind == KIND_ADAPTIVE) | (kind == KIND_VB) | (kind == KIND_ROBUST) | (kind == KIND_IMM))


def learning_state(
    model: Model, filters: Sequence[FilterSpec], ad: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The variational-Bayes filters' start: covariance Δ at their guess σ̂, IG(a₀, a₀σ̂²), (ρ, iterations); the
    robust filters' (c, κ(c)); the adaptive and robust filters' stated σ range (σ_min, σ_max), inside which the loop
    holds their σ̂ (:mod:`isl_core.kernels.scenario`), in the inverse-gamma pair's place."""
    nf, m = len(filters), model.m
    vb_P, vb_ab, vb_par = np.zeros((nf, m, m)), np.zeros((nf, 2)), np.zeros((nf, 2))
    for f, spec in enumerate(filters):
        v = spec.variational
        if v is not None:
            vb_P[f] = kalman_bucy(Model(model.alpha, model.beta, v.sigma_init, m)).delta
            vb_ab[f] = v.shape0, v.shape0 * v.sigma_init**2
            vb_par[f] = v.rho, v.iterations
            ad[f, AD_SIGMA] = v.sigma_init
        if spec.adaptive is not None:
            vb_ab[f] = spec.adaptive.sigma_range
        if spec.huber is not None:
            vb_par[f] = spec.huber, huber_kappa(spec.huber)
        if spec.imm is not None:  # σ̂ of the bank before its first reading: Σ μ_j σ_j at μ_j = 1/J
            ad[f, AD_SIGMA] = spec.imm.sigmas.mean()
    return vb_P, vb_ab, vb_par
