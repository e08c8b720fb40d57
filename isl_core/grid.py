"""The grid of a simulation: its step size h, its length T and its number of steps N (B.46–B.47, :ref:`step-size`).

Step size (B.47): every closed-loop rate must satisfy ``h·|λ| ≪ 1``. We take the fastest rate in play,
``max(|λ(A − KC)|, α, |λ(Λ_f)|, r_min)`` with Λ_f the linearized matrix of each filter (B.46), and set
``h = H_RATE / rate`` (H_RATE = 0.02). The grid itself biases every RMSE by O(h·rate); for the optimal filter the
bias is exact — the stationary covariance of its Euler error recursion, a discrete Lyapunov equation — and grows
with m (3 % at m = 6 with H_RATE alone), so h is shrunk further until that bias is at most EULER_BIAS = 1 %.
Then ``N = ⌈T/h⌉`` and h is shrunk to ``T/N`` so that t_N = T. N is capped (MAX_STORED_STEPS with trajectories,
MAX_STEPS without): beyond, a ``ValueError`` says so.

Length: the horizon is counted in units of 1/r_min (A.24), the settling time of the optimal filter. A filter
whose slowest closed-loop mode (B.46) is slower needs longer to forget its start and to average out:
:func:`settling_rate` is the slowest rate among the filters in play, and ``T = horizon / settling_rate``
("lengthened" by ``r_min / settling_rate``) when another filter is more than SETTLE_TOL = 10 % slower than the
optimal one (a mode 10 % slower has still decayed by e⁻⁹ where the optimal one has by e⁻¹⁰).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .bounds import BOUNDS
from .filters.base import FilterSpec, linearized_matrix
from .filters.isl import isl_filter
from .filters.kalman import optimal_kbf
from .model import Model
from .riccati import KalmanBucy, kalman_bucy
from .theory import lyapunov
from .validate import check_real, short

__all__ = [
    "EULER_BIAS",
    "H_RATE",
    "MAX_STEPS",
    "MAX_STORED_STEPS",
    "SETTLE_TOL",
    "RunPlan",
    "check_filters",
    "check_specs",
    "euler_bias",
    "grid",
    "run_plan",
    "settling_rate",
    "step_size",
]

H_RATE = 0.02  #: h × (fastest rate): the margin of :ref:`step-size`
EULER_BIAS = 0.01  #: largest relative bias the Euler grid may add to the optimal filter's RMSE (exact, see below)
MAX_STORED_STEPS = 4_000_000  #: cap on N when trajectories are kept (memory 8·(m·(filters + 1) + 1)·N bytes)
MAX_STEPS = 200_000_000  #: cap on N when only squared errors are accumulated
SETTLE_TOL = 1.1  #: a filter slower than the optimal one by more than this factor lengthens the run


def euler_bias(model: Model, kb: KalmanBucy, h: float) -> float:
    """Relative bias ``max_i √(P_ii/Δ_ii) − 1`` of the optimal filter's RMSE on the Euler grid of step ``h``.

    Its error obeys ``e_{k+1} = (I + h(A − KC))e_k − βE√h v_k + Kσ√h ε_k`` (B.30, B.33–B.34), whose stationary
    covariance P solves ``P = F P Fᵀ + h(β²EEᵀ + σ²KKᵀ)``, F = I + h(A − KC) — exact, not an estimate.
    """
    K = np.asarray(kb.K)
    M = model.A - np.outer(K, model.C[0])
    Q = model.beta**2 * (model.E @ model.E.T) + model.sigma**2 * np.outer(K, K)
    P = lyapunov(M, Q, h)
    return float(np.max(np.abs(np.sqrt(np.diagonal(P) / np.diagonal(kb.delta)) - 1.0)))


def step_size(model: Model, kb: KalmanBucy, filters: Sequence[FilterSpec]) -> float:
    """``h = H_RATE / max(|λ(A − KC)|, α, |λ(Λ_f)|, r_min)`` (B.47 with a margin, :ref:`step-size`), shrunk until the
    grid biases the optimal filter's RMSE by at most :data:`!EULER_BIAS` (:func:`!euler_bias`).

    Parameters
    ----------
    model : Model
        The model.
    kb : KalmanBucy
        Its solution, :func:`isl_core.kalman_bucy`.
    filters : sequence of FilterSpec
        The filters simulated besides the optimal one.

    Returns
    -------
    float
        The step h.

    Examples
    --------
    >>> from isl_core import isl_filter, kalman_bucy, step_size
    >>> from isl_core.grid import H_RATE
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> kb = kalman_bucy(model)
    >>> h = step_size(model, kb, [isl_filter(model, model.beta)])
    >>> bool(0 < h <= H_RATE / kb.r_min)
    True
    """
    rate = max(float(np.max(np.abs(kb.eig))), model.alpha, kb.r_min)
    for spec in filters:
        rate = max(rate, float(np.max(np.abs(np.linalg.eigvals(linearized_matrix(model, spec))))))
    h = H_RATE / rate
    for _ in range(8):  # the bias is ∝ h for small h: one rescaling nearly always suffices
        bias = euler_bias(model, kb, h)
        if bias <= EULER_BIAS:
            break
        h *= 0.98 * EULER_BIAS / bias
    return h


def settling_rate(model: Model, kb: KalmanBucy, filters: Sequence[FilterSpec]) -> float:
    """Slowest closed-loop rate among the optimal filter and ``filters``: ``min(r_min, min_f −Re λ(Λ_f))`` (B.46).

    Λ_f is the statistically linearized matrix of filter f (:func:`isl_core.linearized_matrix`). An adaptive filter
    settles like the optimal one (its gain follows K(σ̂) → K(σ)); a filter whose Λ_f is not stable has no stationary
    regime to wait for and is left out (its ratio is what the run shows). A filter at most :data:`!SETTLE_TOL` times
    slower than the optimal one counts as settling with it (the result is then exactly r_min).

    Parameters
    ----------
    model : Model
        The model.
    kb : KalmanBucy
        Its solution.
    filters : sequence of FilterSpec
        The other filters.

    Returns
    -------
    float
        The slowest rate, ≤ r_min.

    Examples
    --------
    >>> from isl_core import isl_filter, kalman_bucy, settling_rate
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> kb = kalman_bucy(model)
    >>> bool(0 < settling_rate(model, kb, [isl_filter(model, model.beta)]) <= kb.r_min)
    True
    """
    rate = kb.r_min
    for spec in filters:
        if spec.adaptive is not None:
            continue
        slow = float(np.min(-np.linalg.eigvals(linearized_matrix(model, spec)).real))
        if slow > 0.0 and slow * SETTLE_TOL < kb.r_min:
            rate = min(rate, slow)
    return rate


def grid(
    model: Model,
    kb: KalmanBucy,
    filters: Sequence[FilterSpec],
    T: float | None,
    h: float | None,
    cap: int,
    *,
    default_T: float | None = None,
) -> tuple[float, float, int]:
    """``(T, h, N)`` with ``N·h = T``: ``T`` (default ``default_T``, else 10/r_min), ``h`` by :func:`step_size`."""
    if T is not None:
        T = check_real("T", T, lo=0.0, lo_open=True)
    elif default_T is not None:
        T = default_T
    else:
        T = 10.0 / kb.r_min
    if h is None:
        h = min(step_size(model, kb, filters), T)
    else:
        h = check_real("h", h, lo=0.0, lo_open=True)
        if h > T:
            raise ValueError(f"h must be a finite number > 0 and <= T = {T:g}, got {h:g}")
    steps = T / h  # may overflow to inf for extreme T/h: compared before any integer conversion
    if not steps <= cap:
        raise ValueError(
            f"T/h = {T:g}/{h:.4g} needs {steps:,.0f} steps, over the limit of {cap:,}; shorten T or enlarge h"
        )
    n = max(1, math.ceil(steps - 1e-9))
    return T, T / n, n


def check_filters(model: Model, nu: float, extra: object) -> list[FilterSpec]:
    if not isinstance(model, Model):
        raise ValueError(f"model must be an isl_core.Model, got {type(model).__name__}")
    extra = check_specs("extra", model, extra, allow_empty=True)
    return [isl_filter(model, nu), *extra]  # the ISL filter's constructor checks ν


def check_specs(name: str, model: Model, specs: object, *, allow_empty: bool) -> list[FilterSpec]:
    """``specs`` as a list of :class:`FilterSpec` of the model's size, or a ``ValueError`` naming ``name``."""
    what = f"{name} must be a {'' if allow_empty else 'non-empty '}sequence of FilterSpec of size m = {model.m}"
    if not isinstance(specs, list | tuple | range):
        raise ValueError(f"{what}, got {short(specs)}")
    specs = list(specs)
    if not (specs or allow_empty):
        raise ValueError(f"{what}, got an empty sequence")
    for spec in specs:
        if not isinstance(spec, FilterSpec) or np.shape(spec.coef) != (model.m,):
            raise ValueError(f"{what}, got {short(spec)}")
        log_gain: Any = getattr(spec.adaptive, "log_gain", None)  # whatever a caller put there
        table = None if spec.adaptive is None else np.shape(log_gain)
        if table is not None and not (len(table) == 2 and table[0] >= 2 and table[1] == model.m):
            raise ValueError(f"{what} (an adaptive gain table of shape (n >= 2, m)), got {short(spec)}")
    return specs


@dataclass(frozen=True)
class RunPlan:
    """The grid of a :func:`simulate` call, known before anything is allocated: ``T = N·h``, ``stretch`` (≥ 1)."""

    T: float
    h: float
    N: int
    stretch: float
    r_min: float

    @property
    def horizon(self) -> float:
        """T in units of 1/r_min (A.24)."""
        return self.T * self.r_min


def run_plan(
    model: Model,
    nu: float,
    *,
    horizon: float = 10.0,
    T: float | None = None,
    h: float | None = None,
    extra: Sequence[FilterSpec] = (),
    step_filters: Sequence[FilterSpec] = (),
    cap: int = MAX_STORED_STEPS,
) -> RunPlan:
    """The grid :func:`simulate` would use for these arguments (same rules, same checks, nothing simulated).

    ``cap``: the largest N allowed (a ``ValueError`` past it names T and h).

    Parameters
    ----------
    model, nu, horizon, T, h, extra, step_filters : Model, float, float, float, float, sequence, sequence
        As in :func:`isl_core.simulate`.
    cap : int
        The largest number of steps allowed.

    Returns
    -------
    RunPlan
        ``T``, ``h``, ``N`` (N·h = T), ``stretch`` and ``r_min``.

    Examples
    --------
    >>> import math
    >>> from isl_core import kalman_bucy, run_plan
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> plan = run_plan(model, model.beta, horizon=10.0)
    >>> math.isclose(plan.N * plan.h, plan.T), math.isclose(plan.T, 10.0 * plan.stretch / kalman_bucy(model).r_min)
    (True, True)
    """
    filters = check_filters(model, nu, extra)
    grid_only = check_specs("step_filters", model, step_filters, allow_empty=True)
    horizon = BOUNDS.horizon.real(horizon)
    kb = kalman_bucy(model)
    filters.insert(0, optimal_kbf(model, kb))
    stretch = 1.0 if T is not None else kb.r_min / settling_rate(model, kb, filters[1:2])
    T, h, n = grid(model, kb, [*filters, *grid_only], T, h, cap, default_T=horizon * stretch / kb.r_min)
    return RunPlan(T, h, n, stretch, kb.r_min)
