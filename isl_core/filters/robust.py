"""A robust adaptive Kalman–Bucy filter for heavy-tailed observation noise: Huber's M-estimate of the innovation.

The adaptive filter of :mod:`isl_core.filters.adaptive` (gain K(σ̂) of the CARE at an online estimate σ̂) with every
normalized innovation u passed through Huber's ψ before it enters the state and the variance estimate
(P. J. Huber, "Robust estimation of a location parameter", Ann. Math. Statist. 35(1):73–101, 1964; for the Kalman
filter, C. J. Masreliez and R. D. Martin, "Robust Bayesian estimation for the linear model and robustifying the
Kalman filter", IEEE Trans. Automatic Control 22(3):361–371, 1977):

    ψ(u) = clip(u, −c·σ̂, c·σ̂)                        e ← … + √(qh)·K(σ̂)·ψ(u)
    v ← v + λ (min(u², c²σ̂²)/κ(c) − v),   σ̂² = v / (1 + qh·K_1(σ̂))

κ(c) = E min(Z², c²), Z ~ N(0, 1), makes the clipped second moment consistent for Gaussian noise (σ̂ → σ), so on
Gaussian data the filter is the adaptive one up to the clipped 2·Φ(−c) share of the innovations. c = 1.345 gives
Huber's 95 % efficiency at the Gaussian. A single outlier k times the noise then moves the state by at most
c·σ̂·√(qh)·K instead of k·σ·√(qh)·K.
"""

from __future__ import annotations

import dataclasses
import math

from ..model import Model
from ..validate import check_real
from .adaptive import MEMORY, adaptive_kbf
from .base import SIGMA_RANGE, FilterSpec

__all__ = ["HUBER_C", "huber_kappa", "robust_kbf"]

HUBER_C = 1.345  #: Huber's constant for 95 % efficiency at the Gaussian


def huber_kappa(c: float) -> float:
    """κ(c) = E min(Z², c²) for Z ~ N(0, 1): (2Φ(c) − 1) − 2c·φ(c) + 2c²·(1 − Φ(c))."""
    tail = 0.5 * math.erfc(c / math.sqrt(2.0))  # 1 − Φ(c)
    density = math.exp(-0.5 * c * c) / math.sqrt(2.0 * math.pi)
    return (1.0 - 2.0 * tail) - 2.0 * c * density + 2.0 * c * c * tail


def robust_kbf(
    model: Model,
    *,
    c: float = HUBER_C,
    sigma_range: tuple[float, float] = SIGMA_RANGE,
    memory: float = MEMORY,
    sigma_init: float | None = None,
) -> FilterSpec:
    """The robust adaptive filter (module docstring) for ``model``'s α, β, m; the rest as :func:`adaptive_kbf`
    (``memory`` W in sensor readings).

    Parameters
    ----------
    model : Model
        The model (its α, β, m).
    c : float
        Huber's clipping constant, 0.1 … 10.
    sigma_range, memory, sigma_init : (float, float), float, float
        As in :func:`adaptive_kbf`.

    Returns
    -------
    FilterSpec
        The filter, named ``"kbf_robust"``.

    Examples
    --------
    >>> from isl_core import robust_kbf
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> robust_kbf(model, c=2.0).huber
    2.0
    """
    c = check_real("c (Huber's clipping constant)", c, lo=0.1, hi=10.0)
    spec = adaptive_kbf(model, sigma_range=sigma_range, memory=memory, sigma_init=sigma_init)
    assert spec.adaptive is not None  # adaptive_kbf's gain table
    label = f"Kalman–Bucy, adaptive σ̂, Huber c = {c:g} (W = {spec.adaptive.memory:g} readings)"
    return dataclasses.replace(spec, name="kbf_robust", huber=c, label=label)
