"""An adaptive Kalman–Bucy filter: σ estimated online from the innovations and fed into the gain.

The filter is the Kalman–Bucy scheme (B.30) with the stationary gain K(σ̂) of the CARE (A.21–A.23) at the
current estimate σ̂ instead of the unknown σ. The estimate is innovation-based adaptive estimation
(R. K. Mehra, "On the identification of variances and adaptive Kalman filtering", IEEE Trans. Automatic
Control 15(2):175–184, 1970): the innovation's variance is measured and the part the filter's own error
contributes is subtracted. On the Euler grid (B.34) the normalized innovation is

    u_k = ΔY_k/√h − √h·Ẑ_1(t_k) = σ·ε_k − √h·e_1(t_k),     E u_k² = σ² + h·E e_1²  ≈ σ²·(1 + h·K_1(σ))

(e = Ẑ − X; for a filter near the optimum E e_1² ≈ Δ_11 = σ²K_1 by A.21). This is the quadratic-variation
argument: with fine sampling ΔY/√h ≈ σ·ε, so σ is identifiable from the observation path alone. Each step:

    K = K(σ̂_{k−1}) drives Ẑ_{k+1} (B.30)                       — the gain is known before u_k
    v_k  = v_{k−1} + λ_k (u_k² − v_{k−1}),   λ_k = max(1/k, 1/W)  — running mean, then forgetting over W readings
    σ̂_k² = v_k / (1 + h·K_1(σ̂_{k−1}))                           — Mehra's correction R̂ = Ĉ_0 − H M Hᵀ

**Memory W counts sensor readings** (k above is the reading's number, u_k its normalized innovation): one meaning
for every σ-learning filter (this one, :mod:`isl_core.filters.robust`, :mod:`isl_core.filters.variational`),
whatever the grid's step h or the sensor interval of a scenario (:mod:`isl_core.kernels.scenario`). In paper A's runs
(:func:`isl_core.simulate`) the filters read Y at every step, so there a reading is a step. As a time, W readings
of a sensor read every q steps of h are ``W·q·h`` (``W·q·h·r_min`` in units of 1/r_min:
:meth:`isl_core.ScenarioPlan.memory_time`) — the same W is a different time in every scenario, and the tuning of
:mod:`isl_core.scenario.tuning` chooses it per family by one rule.

In steady state v is an exponentially weighted mean (weight λ = 1/W) of nearly independent u² with
Var u² = 2σ⁴, so ``Var v = λ/(2 − λ)·2σ⁴ = 2σ⁴/(2W − 1)`` and ``sd(σ̂)/σ ≈ 1/√(2(2W − 1)) ≈ 1/(2√W)``: the
constructor's default W = 1000 readings gives ≈ 1.6 %. Since the RMSE is flat at the optimal gain, the cost in RMSE is
second order in that error. A time average of σ̂ over L ≫ W steps is as good as the plain mean of L values
of u²: ``sd ≈ σ/√(2L)``.

The gain K(σ) is read from a table of the exact CARE gain over an equally spaced grid of log σ
(TABLE_PER_DECADE points a decade, from σ_min/TABLE_MARGIN to σ_max·TABLE_MARGIN of the user's σ range),
log K linear in log σ between grid points — exact for α = 0, where K_i = G_i1 (β/σ)^{i/m} (B.18) — and held at
the ends beyond it. The table comes from the normalized CARE (:mod:`isl_core.riccati`): with ϱ = (β/σ)^{1/m},
``K_i = ϱ^i Δ'_{i1}(α/ϱ)``: one small, well-conditioned CARE per grid point (cached).

No theory (statistical linearization) exists for this filter: its predicted ratio is nan.
Symbols: ``memory`` = W (readings), ``sigma_init`` = σ̂ before the first innovation, ``v`` the innovation variance.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import cast

import numpy as np
import numpy.typing as npt

from ..model import Model
from ..riccati import A_MAX, normalized_care
from ..validate import check_real, check_sigma_range, short
from .base import SIGMA_RANGE, AdaptiveGain, FilterSpec

__all__ = [
    "MEMORY",
    "TABLE_MARGIN",
    "TABLE_PER_DECADE",
    "adaptive_kbf",
    "gain_table",
    "normalized_gains",
    "sigma_hat_sd",
    "sigma_limit",
]

MEMORY = 1000.0  #: the constructors' default memory W of the innovation variance, in sensor readings
TABLE_PER_DECADE = 20  #: grid points of the gain table per decade of σ
TABLE_MARGIN = 100.0  #: the table reaches this factor beyond each end of the σ range


def normalized_gains(m: int, a: np.ndarray) -> np.ndarray:
    """First columns Δ'_{i1} (len(a), m) of the normalized CARE ``A'Δ' + Δ'A'ᵀ + EEᵀ − Δ'CᵀCΔ' = 0``,
    ``A' = A0 − a·EEᵀ`` (:mod:`isl_core.riccati`), for every a ≥ 0 in ``a``."""
    return np.array([normalized_care(m, float(x))[:, 0] for x in np.atleast_1d(a)])


@lru_cache(maxsize=64)
def _table(alpha: float, beta: float, m: int, log_sigma0: float, step: float, n: int) -> np.ndarray:
    log_sigma = log_sigma0 + step * np.arange(n)
    log_rho = (math.log(beta) - log_sigma) / m  # ϱ = (β/σ)^{1/m}
    k1 = normalized_gains(m, alpha * np.exp(-log_rho))
    i = np.arange(1, m + 1)
    table = i * log_rho[:, None] + np.log(k1)  # log K_i = i·log ϱ + log Δ'_{i1}
    table.flags.writeable = False
    return cast("np.ndarray", table)


def gain_table(model: Model, sigmas: npt.ArrayLike) -> np.ndarray:
    """Stationary Kalman–Bucy gains K(σ) (len(sigmas), m) of ``model``'s α, β, m at each σ (A.21–A.23)."""
    sig = np.atleast_1d(np.asarray(sigmas, dtype=float))
    log_rho = (math.log(model.beta) - np.log(sig)) / model.m
    return cast(
        "np.ndarray",
        np.exp(np.arange(1, model.m + 1) * log_rho[:, None])
        * normalized_gains(model.m, model.alpha * np.exp(-log_rho)),
    )


def adaptive_kbf(
    model: Model,
    *,
    sigma_range: tuple[float, float] = SIGMA_RANGE,
    memory: float = MEMORY,
    sigma_init: float | None = None,
) -> FilterSpec:
    """The adaptive Kalman–Bucy filter of this module for ``model``'s α, β, m (σ is not used).

    ``sigma_range`` (σ_min, σ_max): the plausible range of σ; the gain table spans it widened by TABLE_MARGIN
    on each side. ``memory``: W in sensor readings (≥ 1; module docstring). ``sigma_init``: σ̂ before the first
    innovation (default the geometric middle √(σ_min σ_max); after the first step the data take over, λ_1 = 1).

    Parameters
    ----------
    model : Model
        The model (its α, β, m).
    sigma_range : (float, float), default (2, 200)
        The plausible range of σ.
    memory : float
        W in sensor readings.
    sigma_init : float, optional
        σ̂ before the first innovation.

    Returns
    -------
    FilterSpec
        The filter, named ``"kbf_adaptive"``, its gain table in ``adaptive``.

    Examples
    --------
    >>> from isl_core import adaptive_kbf
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> spec = adaptive_kbf(model, memory=100.0)
    >>> spec.name, spec.adaptive.memory
    ('kbf_adaptive', 100.0)
    """
    if not isinstance(model, Model):
        raise ValueError(f"model must be an isl_core.Model, got {type(model).__name__}")
    lo, hi = check_sigma_range(sigma_range)
    memory = check_real("memory (W, in sensor readings)", memory, lo=1.0)
    sigma_init = (
        math.sqrt(lo * hi) if sigma_init is None else check_real("sigma_init", sigma_init, lo=0.0, lo_open=True)
    )
    top = sigma_limit(model)
    if hi > top:
        raise ValueError(
            f"sigma_range must end at or below {top:.4g} for alpha = {model.alpha:g}, "
            f"beta = {model.beta:g}, m = {model.m} (the Riccati equation's domain, "
            f"isl_core.riccati.A_MAX), got {short(sigma_range)}"
        )
    log_lo, log_hi = math.log(lo / TABLE_MARGIN), math.log(min(hi * TABLE_MARGIN, top))
    n = max(2, math.ceil(TABLE_PER_DECADE * (log_hi - log_lo) / math.log(10.0)) + 1)
    step = (log_hi - log_lo) / (n - 1)
    table = _table(model.alpha, model.beta, model.m, log_lo, step, n)
    gain = AdaptiveGain(log_lo, step, table, memory, sigma_init, (lo, hi))
    return FilterSpec(
        "kbf_adaptive",
        f"Kalman–Bucy, adaptive σ̂ (W = {memory:g} readings)",
        model.alpha,
        gain.gain(sigma_init),
        False,
        gain,
    )


def sigma_limit(model: Model) -> float:
    """The largest σ whose CARE :func:`isl_core.kalman_bucy` solves for ``model``'s α, β, m: ``β·(A_MAX/α)^m``
    (inf for α = 0 or m = 1), the normalized damping α/ϱ = A_MAX (:mod:`isl_core.riccati`)."""
    if model.alpha == 0.0 or model.m == 1:
        return math.inf
    with np.errstate(over="ignore"):
        return float(model.beta * np.float64(A_MAX / model.alpha) ** model.m)


def sigma_hat_sd(memory: float = MEMORY) -> float:
    """Relative steady-state scatter ``sd(σ̂)/σ ≈ 1/√(2(2W − 1))`` of the estimate (module docstring)."""
    memory = check_real("memory (W, in sensor readings)", memory, lo=1.0)
    return 1.0 / math.sqrt(2.0 * (2.0 * memory - 1.0))
