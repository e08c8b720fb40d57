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
  the :ref:`step-size` rule over all its filters, burn-in BURN and ``horizon`` in units of the settling time of the
  group's slowest filter (:func:`isl_core.sweep.group_length`: 1/r_min, or ``stretch``/r_min where a fixed gain
  far from its design σ or an ISL filter settles slower), the group's seed from
  :func:`isl_core.sweep.group_seed` (independent of chunking and executor), batch-means intervals.
* the interval of a worst case is ``[max over (σ, i) of the lower bounds, max of the upper bounds]`` (as in
  :mod:`isl_core.recommend`); theory is the same max over the predictions (nan for the adaptive filter).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ._engine import freeze
from .filters.adaptive import MEMORY
from .filters.base import SIGMA_RANGE
from .filters.baselines import BASELINES, baseline_filters, check_names
from .filters.baselines import LABELS as BASE_LABELS
from .filters.isl import isl_filter
from .filters.kalman import design_sigma
from .jobs import Task, check_execution, check_sampling, run
from .model import M_MAX, Model
from .paper import FIG2_ALPHAS, a31_nu_over_beta
from .recommend import recommend_nu
from .riccati import kalman_bucy
from .sweep import BURN, group_length, group_seed, pooled_ratios
from .theory import theory_ratios
from .validate import check_int, check_real, check_reals, check_sigma_range, short

__all__ = ["FILTERS", "LABELS", "WorstCaseTable", "worst_case"]

#: the filters of the table: the baselines, with paper A's filter twice — at the minimax ν and at table A.31's
FILTERS = (*BASELINES[:2], "isl_a31", *BASELINES[2:])
#: column labels: each filter AND where its tuning comes from
LABELS = {
    **BASE_LABELS,
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
    ``r_min``, ``h``, ``steps``, ``stretch`` (nα, nσ) per group and seed: burn-in ``BURN·stretch/r_min``, then an
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

    @property
    def labels(self) -> tuple[str, ...]:
        """Short human labels of ``names``, with the origin of each filter's tuning (:data:`!LABELS`)."""
        return tuple(LABELS[n] for n in self.names)

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
        return self.sigmas[self._argworst()[0]]

    @property
    def worst_i(self) -> np.ndarray:
        return self._argworst()[1] + 1

    @property
    def theory_worst(self) -> np.ndarray:
        """``max_{σ, i}`` predicted ratio (nα, nf); nan where no theory exists."""
        return _max_over(self.theory)

    def records(self) -> list[dict]:
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
                        "label": LABELS[name],
                        "worst": float(worst[a, f]),
                        "worst_low": float(lo[a, f]),
                        "worst_high": float(hi[a, f]),
                        "worst_sigma": float(ws[a, f]),
                        "worst_i": int(wi[a, f]),
                        "theory_worst": float(th[a, f]),
                        "nu": float(self.nu[a, f]),
                        "sigma_design": float(self.sigma_design[a, f]),
                        "burn_in_over_r_min": BURN * float(self.stretch[a, at[a, f]]),
                        "window_over_r_min": self.horizon * float(self.stretch[a, at[a, f]]),
                    }
                )
        return rows


def _max_over(x: np.ndarray) -> np.ndarray:
    """Max over σ (axis 1) and i (axis 3); nan if any entry is nan (a diverged filter has no finite worst case)."""
    return x.max(axis=(1, 3))


def _plan(alphas, sigmas, names, m, w, sigma_design, memory, horizon, seeds, batches):
    """Per-α tunings, every group's task (most expensive first), and per-(α, σ) theory, s, r_min, h, steps."""
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
            T, n, stretch[a, b] = group_length(model, kb, filters, horizon)
            s[a, b], r_min[a, b], h[a, b], steps[a, b] = kb.s, kb.r_min, T / n, n
            for k, seed in enumerate(seeds):
                tasks.append(
                    Task(
                        (a, b, k),
                        model,
                        filters,
                        T,
                        T / n,
                        BURN * stretch[a, b] / kb.r_min,
                        batches,
                        group_seed(seed, alpha, sigma, w, m),
                        n,
                    )
                )
    tasks.sort(key=lambda t: -t.cost)
    return nu, design, best, theory, tasks, s, r_min, h, steps, stretch, cols


def _filter(model: Model, name: str, nu_a31: float, kw: dict):
    """Filter ``name`` of :data:`!FILTERS` for ``model``: a baseline, or paper A's ISL filter at table A.31's ν."""
    if name == "isl_a31":
        spec = isl_filter(model, nu_a31)
        return dataclasses.replace(spec, name="isl_a31", label=f"ISL, ν from table A.31 (ν = {nu_a31:.4g})")
    return baseline_filters(model, names=(name,), **kw)[0]


def _check(alphas, sigma_range, n_sigma, m, w, sigma_design, memory, horizon, seeds, batches, level):
    alphas = check_reals("alphas", alphas, lo=0.0, lo_open=True)
    lo, hi = check_sigma_range(sigma_range)
    if not hi > lo:
        raise ValueError(f"sigma_range must have sigma_max > sigma_min, got {short(sigma_range)}")
    n_sigma = check_int("n_sigma", n_sigma, lo=2, hi=101)
    m = check_int("m", m, lo=1, hi=M_MAX)
    w = check_real("w", w, lo=0.0, lo_open=True)
    if sigma_design is not None:
        sigma_design = check_real("sigma_design", sigma_design, lo=0.0, lo_open=True)
    memory = check_real("memory (W, in readings)", memory, lo=1.0)
    horizon, seeds, batches, level = check_sampling(horizon, seeds, batches, level)
    sigmas = np.geomspace(lo, hi, n_sigma)
    sigmas[0], sigmas[-1] = lo, hi  # exact ends
    return alphas, sigmas, m, w, sigma_design, memory, horizon, seeds, batches, level


def worst_case(
    alphas: Sequence[float] = FIG2_ALPHAS,
    *,
    sigma_range: tuple[float, float] = SIGMA_RANGE,
    n_sigma: int = 5,
    m: int = 3,
    w: float = 3.0,
    filters: Sequence[str] = FILTERS,
    sigma_design: float | None = None,
    memory: float = MEMORY,
    horizon: float = 1000.0,
    seeds: Sequence[int] = (0, 1),
    batches: int = 10,
    level: float = 0.95,
    executor=None,
    chunk: int = 1,
    workers: int | None = None,
    progress: Callable[[float], None] | None = None,
) -> WorstCaseTable:
    """Each filter's worst-case RMSE ratio over ``sigma_range`` (``n_sigma`` log-spaced σ) per α > 0.

    ``filters``: names from :data:`!FILTERS` (default all): the baselines of :ref:`baselines` and
    ``isl_a31``, paper A's filter at table A.31's ν (for the α of that table; nan elsewhere). ``sigma_design``: σ̄ of the
    mismatched Kalman–Bucy filter (default √(σ_min σ_max)); ``memory``: the adaptive filter's W in readings (a
    reading is a step in these runs).
    ``horizon`` (in 1/r_min), ``seeds``, ``batches``, ``level``, ``executor``, ``chunk``, ``workers`` and
    ``progress`` as in :func:`isl_core.sweep`: results do not depend on the executor or on chunking.

    Parameters
    ----------
    alphas : sequence of float
        The α > 0 (default paper A's Fig. 2).
    sigma_range, n_sigma : (float, float), int
        The σ range (default (2, 200)) and its number of log-spaced values.
    m, w : int, float
        State dimension; stationary std of X_m (β = w√(2α)).
    filters : sequence of str
        The filters compared (default :data:`!FILTERS`).
    sigma_design, memory : float
        σ̄ of the mismatched filter; the adaptive filter's W in readings.
    horizon, seeds, batches, level, executor, chunk, workers, progress
        As in :func:`isl_core.sweep`.

    Returns
    -------
    WorstCaseTable
        ``ratio`` (nα, nσ, filters, m) with intervals and the predicted ``theory``; ``names`` the filters.

    Examples
    --------
    >>> from isl_core import worst_case
    >>> table = worst_case([1.0], sigma_range=(2.0, 20.0), n_sigma=2, filters=["kbf", "isl"], horizon=20.0,
    ...                    seeds=(0,), batches=2, workers=1)
    >>> table.names, table.ratio.shape
    (('kbf', 'isl'), (1, 2, 2, 3))
    """
    alphas, sigmas, m, w, sigma_design, memory, horizon, seeds, batches, level = _check(
        alphas, sigma_range, n_sigma, m, w, sigma_design, memory, horizon, seeds, batches, level
    )
    names = check_names(filters, "filters", FILTERS)
    chunk, workers = check_execution(chunk, workers, progress)
    nu, design, best, theory, tasks, s, r_min, h, steps, stretch, cols = _plan(
        alphas, sigmas, names, m, w, sigma_design, memory, horizon, seeds, batches
    )
    out = run(tasks, executor=executor, workers=workers, chunk=chunk, progress=progress)
    ratio, low, high = pooled_ratios(out, s, level, len(seeds), batches, len(names), cols)
    return WorstCaseTable(
        freeze(alphas),
        freeze(sigmas),
        names,
        m,
        w,
        horizon,
        tuple(seeds),
        batches,
        level,
        freeze(ratio),
        freeze(low),
        freeze(high),
        freeze(theory),
        freeze(nu),
        freeze(design),
        freeze(best[0]),
        freeze(best[1]),
        freeze(r_min),
        freeze(h),
        freeze(steps, np.int64),
        freeze(stretch),
    )
