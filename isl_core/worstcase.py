"""Worst case over an unknown σ: each filter's largest RMSE ratio over a σ range, per α (:ref:`worst-case`).

For a user who knows only that σ lies in ``[σ_min, σ_max]``, the number that matters for a filter is

    W_f(α) = max_{σ ∈ grid, i = 1..m}  š_{f,i}(σ) / s_i(σ)

on a log-spaced grid of ``n_sigma`` values of σ in the range (both ends included), β = w√(2α) (A.25).
The filters are those of :mod:`isl_core.filters.baselines`, all on ONE trajectory per (α, σ, seed) (common
random numbers). Choices, all documented:

* ISL filters: ν from :func:`isl_core.recommend_nu` over the same σ grid (the prediction's minimax ν, not
  verified there: this table is the verification), separately for paper A's filter ("ISL, minimax ν") and the
  model-aware one; and paper A's filter at the ν/β of table (A.31) ("ISL, ν from table A.31",
  :mod:`isl_core.paper`) for the α the table holds (m = 3, w = 3; other α: not simulated, nan).
* mismatched KBF: σ̄ = √(σ_min σ_max) unless ``sigma_design`` is given; minimax KBF: σ̄ = σ_max;
  adaptive KBF: its table and start from the same range, memory ``memory`` (readings = steps here).
* simulation: the sweep machinery of :mod:`isl_core.sweep` — one group per (α, σ, seed) with the step h of
  the :ref:`step-size` rule over all its filters, a burn-in (default SWEEP_BURN) and ``horizon`` in units of the
  settling time of the group's slowest filter (:func:`isl_core.sweep.group_length`: 1/r_min, or ``stretch``/r_min
  where a fixed gain far from its design σ or an ISL filter settles slower), the group's seed from
  :func:`isl_core.sweep.group_seed` (independent of chunking and executor), batch-means intervals.
* the interval of a worst case is ``[max over (σ, i) of the lower bounds, max of the upper bounds]`` (as in
  :mod:`isl_core.recommend`); theory is the same max over the predictions (nan for the adaptive filter).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from ._engine import freeze
from .bounds import BOUNDS
from .filters.adaptive import MEMORY
from .filters.base import SIGMA_RANGE, FilterSpec
from .filters.baselines import BASELINES, baseline_filters, check_names
from .filters.baselines import LABELS as FILTER_LABELS
from .filters.isl import isl_filter
from .filters.kalman import design_sigma
from .jobs import Task, run
from .model import Model
from .paper import FIG2_ALPHAS, a31_nu_over_beta
from .recommend import recommend_nu
from .requests import SWEEP_BURN, Execution, Sampling
from .riccati import kalman_bucy
from .sweep import check_requests, group_length, group_seed, pooled_ratios
from .theory import theory_ratios
from .validate import check_int, check_real, check_reals, check_sigma_range, short

__all__ = ["WORST_CASE_FILTERS", "WORST_CASE_LABELS", "Candidates", "WorstCaseTable", "worst_case"]

#: the filters of the table: the baselines, with paper A's filter twice — at the minimax ν and at table A.31's
WORST_CASE_FILTERS = (*BASELINES[:2], "isl_a31", *BASELINES[2:])
#: the table's column labels: each filter AND where its tuning comes from
WORST_CASE_LABELS = {
    **FILTER_LABELS,
    "isl": "ISL, minimax ν",
    "isl_a31": "ISL, ν from table A.31",
    "isl_model": "ISL model-aware, minimax ν",
}


@dataclass(frozen=True)
class WorstCaseTable:
    """Worst-case RMSE ratios per α and filter over a σ range (module docstring); filters along ``names``.

    Per σ: ``ratio``, ``low``, ``high`` (nα, nσ, nf, m) simulated š_i/s_i with its interval at ``level``,
    ``theory`` (nα, nσ, nf, m) predicted (nan where no theory exists). Worst cases (nα, nf): ``worst`` with
    ``[worst_low, worst_high]``, at ``worst_sigma`` and coordinate ``worst_i`` (1-based), ``theory_worst``.
    Parameters per α and filter (nα, nf): ``nu`` of the ISL filters and ``sigma_design`` of the fixed-gain
    Kalman–Bucy filters (nan elsewhere). ``best_fixed_worst``/``best_fixed_sigma`` (nα,): the best fixed-gain
    Kalman–Bucy design over the range and its predicted worst case (:func:`!isl_core.recommend.best_fixed_kbf`).
    ``r_min``, ``h``, ``steps``, ``stretch`` (nα, nσ) per group and seed: burn-in ``burn·stretch/r_min``, then an
    average over ``horizon·stretch/r_min``.
    """

    alphas: np.ndarray
    sigmas: np.ndarray
    names: tuple[str, ...]
    m: int
    w: float
    horizon: float
    seeds: tuple[int, ...]
    batches: int
    level: float
    ratio: np.ndarray
    low: np.ndarray
    high: np.ndarray
    theory: np.ndarray
    nu: np.ndarray
    sigma_design: np.ndarray
    best_fixed_worst: np.ndarray
    best_fixed_sigma: np.ndarray
    r_min: np.ndarray
    h: np.ndarray
    steps: np.ndarray
    stretch: np.ndarray
    burn: float = SWEEP_BURN

    @property
    def labels(self) -> tuple[str, ...]:
        """Short human labels of ``names``, with the origin of each filter's tuning (:data:`!WORST_CASE_LABELS`)."""
        return tuple(WORST_CASE_LABELS[n] for n in self.names)

    @property
    def sigma_range(self) -> tuple[float, float]:
        return float(self.sigmas[0]), float(self.sigmas[-1])

    def _argworst(self) -> tuple[np.ndarray, np.ndarray]:
        na, ns, nf, m = self.ratio.shape
        flat = np.where(np.isnan(self.ratio), -np.inf, self.ratio).transpose(0, 2, 1, 3).reshape(na, nf, ns * m)
        return np.unravel_index(np.argmax(flat, axis=-1), (ns, m))

    @property
    def worst(self) -> np.ndarray:
        """``max_{σ, i}`` simulated ratio (nα, nf); nan if the filter diverged at some σ."""
        return _max_over(self.ratio)

    @property
    def worst_low(self) -> np.ndarray:
        return _max_over(self.low)

    @property
    def worst_high(self) -> np.ndarray:
        return _max_over(self.high)

    @property
    def worst_sigma(self) -> np.ndarray:
        return cast("np.ndarray", self.sigmas[self._argworst()[0]])

    @property
    def worst_i(self) -> np.ndarray:
        return self._argworst()[1] + 1

    @property
    def theory_worst(self) -> np.ndarray:
        """``max_{σ, i}`` predicted ratio (nα, nf); nan where no theory exists."""
        return _max_over(self.theory)

    def records(self) -> list[dict[str, Any]]:
        """One row per (α, filter) with the worst case, its interval, where it sits, theory and parameters."""
        rows = []
        worst, lo, hi, th = self.worst, self.worst_low, self.worst_high, self.theory_worst
        ws, wi = self.worst_sigma, self.worst_i
        at = self._argworst()[0]  # σ index of each worst case: its group's averaging window
        for a, alpha in enumerate(self.alphas):
            for f, name in enumerate(self.names):
                rows.append(
                    {
                        "alpha": float(alpha),
                        "beta": float(self.w * math.sqrt(2.0 * alpha)),
                        "filter": name,
                        "label": WORST_CASE_LABELS[name],
                        "worst": float(worst[a, f]),
                        "worst_low": float(lo[a, f]),
                        "worst_high": float(hi[a, f]),
                        "worst_sigma": float(ws[a, f]),
                        "worst_i": int(wi[a, f]),
                        "theory_worst": float(th[a, f]),
                        "nu": float(self.nu[a, f]),
                        "sigma_design": float(self.sigma_design[a, f]),
                        "burn_in_over_r_min": self.burn * float(self.stretch[a, at[a, f]]),
                        "window_over_r_min": self.horizon * float(self.stretch[a, at[a, f]]),
                    }
                )
        return rows


def _max_over(x: np.ndarray) -> np.ndarray:
    """Max over σ (axis 1) and i (axis 3); nan if any entry is nan (a diverged filter has no finite worst case)."""
    return cast("np.ndarray", x.max(axis=(1, 3)))


@dataclass(frozen=True)
class _Plan:
    """A worst-case table's tunings per α and filter, its tasks (most expensive first) and, per (α, σ), what the
    results are measured against; ``cols[a]``: where the filters simulated at α number ``a`` go among the names."""

    nu: np.ndarray
    design: np.ndarray
    best: np.ndarray
    theory: np.ndarray
    tasks: list[Task]
    s: np.ndarray
    r_min: np.ndarray
    h: np.ndarray
    steps: np.ndarray
    stretch: np.ndarray
    cols: list[tuple[int, ...]]


def _plan(
    alphas: np.ndarray,
    sigmas: np.ndarray,
    names: Sequence[str],
    m: int,
    w: float,
    sigma_design: float | None,
    memory: float,
    sampling: Sampling,
) -> _Plan:
    """Per-α tunings, every group's task, and per-(α, σ) theory, s, r_min, h, steps."""
    na, ns, nf = len(alphas), len(sigmas), len(names)
    lo, hi = float(sigmas[0]), float(sigmas[-1])
    nu, design = np.full((na, nf), np.nan), np.full((na, nf), np.nan)
    best = np.empty((2, na))
    theory = np.empty((na, ns, nf, m))
    s, r_min, h, steps = np.empty((na, ns, m)), np.empty((na, ns)), np.empty((na, ns)), np.empty((na, ns), np.int64)
    stretch = np.empty((na, ns))
    tasks = []
    cols = []
    for a, alpha in enumerate(alphas):
        rec = recommend_nu(alpha, sigmas=sigmas, m=m, w=w, verify=False)
        nu_model = recommend_nu(alpha, sigmas=sigmas, m=m, w=w, verify=False, model_aware=True).nu
        a31 = a31_nu_over_beta(alpha, m, w)
        nu_a31 = math.nan if a31 is None else a31 * w * math.sqrt(2.0 * alpha)
        best[:, a] = rec.kbf_worst, rec.kbf_sigma_design
        present = tuple(n for n in names if not (n == "isl_a31" and a31 is None))  # (A.31) holds 5 α only
        cols.append(tuple(names.index(n) for n in present))
        kw = {
            "nu": rec.nu,
            "nu_model": nu_model,
            "sigma_design": sigma_design,
            "sigma_range": (lo, hi),
            "memory": memory,
        }
        for f, name in enumerate(names):
            nu[a, f] = {"isl": rec.nu, "isl_model": nu_model, "isl_a31": nu_a31}.get(name, math.nan)
            design[a, f] = {
                "kbf_mismatched": design_sigma((lo, hi)) if sigma_design is None else sigma_design,
                "kbf_minimax": hi,
            }.get(name, math.nan)
        for b, sigma in enumerate(sigmas):
            model = Model.from_w(alpha, w, sigma, m)
            kb = kalman_bucy(model)
            filters = tuple(_filter(model, name, nu_a31, kw) for name in present)
            theory[a, b] = np.nan
            theory[a, b, list(cols[a])] = [theory_ratios(model, spec) for spec in filters]
            T, n, stretch[a, b] = group_length(model, kb, filters, sampling.horizon, sampling.burn)
            s[a, b], r_min[a, b], h[a, b], steps[a, b] = kb.s, kb.r_min, T / n, n
            burn = sampling.burn * stretch[a, b] / kb.r_min
            for k, seed in enumerate(sampling.seeds):
                key = group_seed(seed, alpha, sigma, w, m)
                tasks.append(Task((a, b, k), model, filters, T, T / n, burn, sampling.batches, key, n))
    tasks.sort(key=lambda t: -t.cost)
    return _Plan(nu, design, best, theory, tasks, s, r_min, h, steps, stretch, cols)


def _filter(model: Model, name: str, nu_a31: float, kw: dict[str, Any]) -> FilterSpec:
    """Filter ``name`` of :data:`!WORST_CASE_FILTERS` for ``model``: a baseline, or paper A's ISL filter at table
    A.31's ν."""
    if name == "isl_a31":
        spec = isl_filter(model, nu_a31)
        return dataclasses.replace(spec, name="isl_a31", label=f"ISL, ν from table A.31 (ν = {nu_a31:.4g})")
    return baseline_filters(model, names=(name,), **kw)[0]


def _check(
    alphas: object,
    sigma_range: object,
    n_sigma: object,
    m: object,
    w: object,
    sigma_design: object,
    memory: object,
) -> tuple[np.ndarray, np.ndarray, int, float, float | None, float]:
    alphas = check_reals("alphas", alphas, lo=0.0, lo_open=True)  # β = w·√(2α) needs α > 0
    lo, hi = check_sigma_range(sigma_range)
    if not hi > lo:
        raise ValueError(f"sigma_range must have sigma_max > sigma_min, got {short(sigma_range)}")
    n_sigma = check_int("n_sigma", n_sigma, lo=2, hi=101)
    m = BOUNDS.m.whole(m)
    w = BOUNDS.w.real(w)
    if sigma_design is not None:
        sigma_design = BOUNDS.sigma.real(sigma_design, "sigma_design")
    memory = check_real("memory (W, in readings)", memory, lo=1.0)
    sigmas = np.geomspace(lo, hi, n_sigma)
    sigmas[0], sigmas[-1] = lo, hi  # exact ends
    return alphas, sigmas, m, w, sigma_design, memory


@dataclass(frozen=True)
class Candidates:
    """The filters a worst-case table compares and how the fixed ones are set: ``names`` from
    :data:`!WORST_CASE_FILTERS` (default all of them), ``sigma_design`` the σ̄ of the mismatched Kalman–Bucy filter
    (None: √(σ_min σ_max)), ``memory`` the adaptive filter's W in readings (a reading is a step in these runs)."""

    names: tuple[str, ...] = WORST_CASE_FILTERS
    sigma_design: float | None = None
    memory: float = MEMORY


def worst_case(
    alphas: Sequence[float] | np.ndarray = FIG2_ALPHAS,
    *,
    sigma_range: tuple[float, float] = SIGMA_RANGE,
    n_sigma: int = 5,
    m: int = 3,
    w: float = 3.0,
    candidates: Candidates | None = None,
    sampling: Sampling | None = None,
    execution: Execution | None = None,
) -> WorstCaseTable:
    """Each filter's worst-case RMSE ratio over ``sigma_range`` (``n_sigma`` log-spaced σ) per α > 0.

    ``candidates`` (:class:`isl_core.Candidates`): the filters, names from :data:`!WORST_CASE_FILTERS` (default all):
    the baselines of :ref:`baselines` and ``isl_a31``, paper A's filter at table A.31's ν (for the α of that table;
    nan elsewhere); the mismatched Kalman–Bucy filter's σ̄ (default √(σ_min σ_max)) and the adaptive filter's memory.
    ``sampling`` and ``execution`` as in :func:`isl_core.sweep`: results do not depend on the execution.

    Parameters
    ----------
    alphas : sequence of float
        The α > 0 (default paper A's Fig. 2).
    sigma_range, n_sigma : (float, float), int
        The σ range (default (2, 200)) and its number of log-spaced values.
    m, w : int, float
        State dimension; stationary std of X_m (β = w√(2α)).
    candidates : Candidates, optional
        The filters compared and their settings (default ``Candidates()``: every filter of :data:`!WORST_CASE_FILTERS`).
    sampling, execution : Sampling, Execution, optional
        As in :func:`isl_core.sweep`.

    Returns
    -------
    WorstCaseTable
        ``ratio`` (nα, nσ, filters, m) with intervals and the predicted ``theory``; ``names`` the filters.

    Examples
    --------
    >>> from isl_core import Candidates, Execution, Sampling, worst_case
    >>> table = worst_case([1.0], sigma_range=(2.0, 20.0), n_sigma=2, candidates=Candidates(("kbf", "isl")),
    ...                    sampling=Sampling((0,), 20.0, batches=2), execution=Execution(workers=1))
    >>> table.names, table.ratio.shape
    (('kbf', 'isl'), (1, 2, 2, 3))
    """
    cand = Candidates() if candidates is None else candidates
    if not isinstance(cand, Candidates):
        raise ValueError(f"candidates must be an isl_core.Candidates, got {short(cand)}")
    alphas, sigmas, m, w, sigma_design, memory = _check(
        alphas, sigma_range, n_sigma, m, w, cand.sigma_design, cand.memory
    )
    names = check_names(cand.names, "filters", WORST_CASE_FILTERS)
    sampling, execution = check_requests(sampling, execution)
    plan = _plan(alphas, sigmas, names, m, w, sigma_design, memory, sampling)
    out = run(plan.tasks, execution)
    ratio, low, high = pooled_ratios(
        out, plan.s, sampling.level, sampling.n_seeds, sampling.batches, len(names), plan.cols
    )
    return WorstCaseTable(
        freeze(alphas),
        freeze(sigmas),
        names,
        m,
        w,
        sampling.horizon,
        sampling.seeds,
        sampling.batches,
        sampling.level,
        freeze(ratio),
        freeze(low),
        freeze(high),
        freeze(plan.theory),
        freeze(plan.nu),
        freeze(plan.design),
        freeze(plan.best[0]),
        freeze(plan.best[1]),
        freeze(plan.r_min),
        freeze(plan.h),
        freeze(plan.steps, np.int64),
        freeze(plan.stretch),
        sampling.burn,
    )
