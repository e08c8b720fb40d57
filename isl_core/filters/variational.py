"""The variational-Bayes adaptive Kalman filter (S. Särkkä and A. Nummenmaa, "Recursive noise adaptive Kalman
filtering by variational Bayesian approximations", IEEE Trans. Automatic Control 54(3):596–600, 2009).

The observation noise variance σ² is unknown and given an inverse-gamma law IG(a, b) that the filter carries with
its Gaussian state (mean, covariance P): a conjugate pair updated by a few fixed-point iterations per reading.
On the grid of a scenario run (:mod:`isl_core.kernels.scenario`) the reading is the normalized innovation
u = y − H·X̂⁻ of y = ΔY/√(qh) with H = √(qh)·C (q steps per sensor reading); per step

    predict   X̂⁻ = F X̂,  P⁻ = F P Fᵀ + h β² E Eᵀ                             (F = I + h A)

and per reading

    forget    a⁻ = ρ a,  b⁻ = ρ b                                            (ρ = 1 − 1/W, W the memory)
    update    a = a⁻ + ½;  b = b⁻;  repeat N times:
                σ̂² = b/a,  S = H P⁻ Hᵀ + σ̂²,  K = P⁻ Hᵀ / S,
                X̂ = X̂⁻ + K u,  P = P⁻ − K S Kᵀ,
                b = b⁻ + ½ (y − H X̂)² + ½ H P Hᵀ

(the paper's Algorithm 1 for one scalar measurement). The filter knows α, β and m — the model — but not σ. Its memory
W counts sensor readings, as the adaptive filter's of :mod:`isl_core.filters.adaptive` (the two then forget at the
same rate): a⁻ = ρ a with ρ = 1 − 1/W keeps the estimate's weight a at about W/2 (its shape gains ½ a reading), and as
a time W readings are W·q·h (:meth:`isl_core.ScenarioPlan.memory_time`). It starts at the stationary covariance of its
initial guess σ̂ (the Kalman–Bucy Δ at σ_init), with shape a₀ (weight of the guess, in readings) and b₀ = a₀·σ_init².

In error coordinates (e = X̂ − X, as every filter of the kernel) the residual after the update is
y − H X̂ = u·(1 − √(qh)·K_1) and the prediction adds F·K·u to the propagated error.
"""

from __future__ import annotations

import numpy as np

from ..model import Model
from ..riccati import kalman_bucy
from ..validate import check_int, check_real
from .adaptive import MEMORY
from .base import FilterSpec, VariationalGain

__all__ = ["ITERATIONS", "SHAPE0", "variational_kbf"]

ITERATIONS = 3  #: fixed-point iterations per reading (the paper reports convergence in a few)
SHAPE0 = 1.0  #: a₀: the initial guess weighs as much as about two readings


def variational_kbf(
    model: Model,
    *,
    sigma_init: float | None = None,
    memory: float = MEMORY,
    shape0: float = SHAPE0,
    iterations: int = ITERATIONS,
) -> FilterSpec:
    """The variational-Bayes adaptive Kalman filter for ``model`` (module docstring); ``sigma_init`` its guess
    before the first reading (default: the model's σ, as for the other filters' start), ``memory`` W in sensor
    readings (> 1: ρ = 1 − 1/W > 0).

    Parameters
    ----------
    model : Model
        The model.
    sigma_init : float, optional
        σ guessed before the first reading.
    memory : float
        W in sensor readings.
    shape0 : float
        a₀, the prior's shape: how much the initial guess weighs (:data:`!SHAPE0`).
    iterations : int
        Fixed-point iterations per reading.

    Returns
    -------
    FilterSpec
        The filter, named ``"vb"``.

    Examples
    --------
    >>> from isl_core import variational_kbf
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> variational_kbf(model, memory=100.0).name
    'vb'
    """
    sigma0 = model.sigma if sigma_init is None else check_real("sigma_init", sigma_init, lo=0.0, lo_open=True)
    memory = check_real("memory (W, in sensor readings)", memory, lo=1.0, lo_open=True)
    shape0 = check_real("shape0", shape0, lo=0.0, lo_open=True)
    iterations = check_int("iterations", iterations, lo=1, hi=50)
    kb = kalman_bucy(Model(model.alpha, model.beta, sigma0, model.m))
    return FilterSpec(
        "vb",
        f"variational Bayes (σ learnt, Särkkä & Nummenmaa; W = {memory:g} readings)",
        model.alpha,
        np.array(kb.K, dtype=float),
        False,
        variational=VariationalGain(memory, sigma0, shape0, iterations),
    )
