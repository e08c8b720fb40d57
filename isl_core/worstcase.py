"""Worst case over an unknown σ: each filter's largest RMSE ratio over a σ range, per α (SPEC §5–§7).

For a user who knows only that σ lies in ``[σ_min, σ_max]``, the number that matters for a filter is

    W_f(α) = max_{σ ∈ grid, i = 1..m}  š_{f,i}(σ) / s_i(σ)

on a log-spaced grid of ``n_sigma`` values of σ in the range (both ends included), β = w√(2α) (A.25).
The filters are those of :mod:`isl_core.baselines`, all on ONE trajectory per (α, σ, seed) (common random
numbers). Choices, all documented:

* ISL filters: ν from :func:`isl_core.recommend_nu` over the same σ grid (the prediction's minimax ν, not
  verified there: this table is the verification), separately for paper A's filter and the model-aware one.
* mismatched KBF: σ̄ = √(σ_min σ_max) unless ``sigma_design`` is given; minimax KBF: σ̄ = σ_max;
  adaptive KBF: its table and start from the same range, window ``window``.
* simulation: the sweep machinery of :mod:`isl_core.sweep` — one group per (α, σ, seed) with the step h of
  the SPEC §4 rule over all its filters, burn-in BURN and ``horizon`` in units of the settling time of the
  group's slowest filter (:func:`isl_core.sweep.group_length`: 1/r_min, or ``stretch``/r_min where a fixed gain
  far from its design σ or an ISL filter settles slower), the group's seed from
  :func:`isl_core.sweep.group_seed` (independent of chunking and executor), batch-means intervals.
* the interval of a worst case is ``[max over (σ, i) of the lower bounds, max of the upper bounds]`` (as in
  :mod:`isl_core.recommend`); theory is the same max over the predictions (nan for the adaptive filter).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .validate import check_int, check_real, check_reals, short
from .adaptive import WINDOW, check_sigma_range
from .baselines import BASELINES, LABELS, baseline_filters, check_names, design_sigma, theory_ratios
from .model import M_MAX, Model
from .recommend import recommend_nu
from .riccati import kalman_bucy
from .sweep import (
    BURN,
    FIG2_ALPHAS,
    _check_execution,
    _check_sampling,
    _local,
    _Progress,
    _remote,
    _Task,
    group_length,
    group_seed,
    ratio_interval,
)

__all__ = ["WorstCaseTable", "worst_case"]


def _frozen(a, dtype=float) -> np.ndarray:
    a = np.array(a, dtype=dtype)
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class WorstCaseTable:
    """Worst-case RMSE ratios per α and filter over a σ range (module docstring); filters along ``names``.

    Per σ: ``ratio``, ``low``, ``high`` (nα, nσ, nf, m) simulated š_i/s_i with its interval at ``level``,
    ``theory`` (nα, nσ, nf, m) predicted (nan where no theory exists). Worst cases (nα, nf): ``worst`` with
    ``[worst_low, worst_high]``, at ``worst_sigma`` and coordinate ``worst_i`` (1-based), ``theory_worst``.
    Parameters per α and filter (nα, nf): ``nu`` of the ISL filters and ``sigma_design`` of the fixed-gain
    Kalman–Bucy filters (nan elsewhere). ``best_fixed_worst``/``best_fixed_sigma`` (nα,): the best fixed-gain
    Kalman–Bucy design over the range and its predicted worst case (:func:`isl_core.recommend.best_fixed_kbf`).
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
        """Short human labels of ``names`` (:data:`isl_core.baselines.LABELS`)."""
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
                rows.append({
                    "alpha": float(alpha), "beta": float(self.w * math.sqrt(2.0 * alpha)), "filter": name,
                    "label": LABELS[name], "worst": float(worst[a, f]), "worst_low": float(lo[a, f]),
                    "worst_high": float(hi[a, f]), "worst_sigma": float(ws[a, f]), "worst_i": int(wi[a, f]),
                    "theory_worst": float(th[a, f]), "nu": float(self.nu[a, f]),
                    "sigma_design": float(self.sigma_design[a, f]),
                    "burn_in_over_r_min": BURN * float(self.stretch[a, at[a, f]]),
                    "window_over_r_min": self.horizon * float(self.stretch[a, at[a, f]]),
                })
        return rows


def _max_over(x: np.ndarray) -> np.ndarray:
    """Max over σ (axis 1) and i (axis 3); nan if any entry is nan (a diverged filter has no finite worst case)."""
    return x.max(axis=(1, 3))


def _plan(alphas, sigmas, names, m, w, sigma_design, window, horizon, seeds, batches):
    """Per-α tunings, every group's task (most expensive first), and per-(α, σ) theory, s, r_min, h, steps."""
    na, ns, nf = len(alphas), len(sigmas), len(names)
    lo, hi = float(sigmas[0]), float(sigmas[-1])
    nu, design = np.full((na, nf), np.nan), np.full((na, nf), np.nan)
    best = np.empty((2, na))
    theory = np.empty((na, ns, nf, m))
    s, r_min, h, steps = np.empty((na, ns, m)), np.empty((na, ns)), np.empty((na, ns)), np.empty((na, ns), np.int64)
    stretch = np.empty((na, ns))
    tasks = []
    for a, alpha in enumerate(alphas):
        rec = recommend_nu(alpha, sigmas=sigmas, m=m, w=w, verify=False)
        nu_model = recommend_nu(alpha, sigmas=sigmas, m=m, w=w, verify=False, model_aware=True).nu
        best[:, a] = rec.kbf_worst, rec.kbf_sigma_design
        kw = {"nu": rec.nu, "nu_model": nu_model, "sigma_design": sigma_design, "sigma_range": (lo, hi),
              "window": window, "names": names}
        for f, name in enumerate(names):
            nu[a, f] = {"isl": rec.nu, "isl_model": nu_model}.get(name, math.nan)
            design[a, f] = {"kbf_mismatched": design_sigma((lo, hi)) if sigma_design is None else sigma_design,
                            "kbf_minimax": hi}.get(name, math.nan)
        for b, sigma in enumerate(sigmas):
            model = Model.from_w(alpha, w, sigma, m)
            kb = kalman_bucy(model)
            filters = tuple(baseline_filters(model, **kw))
            theory[a, b] = [theory_ratios(model, spec) for spec in filters]
            T, n, stretch[a, b] = group_length(model, kb, filters, horizon)
            s[a, b], r_min[a, b], h[a, b], steps[a, b] = kb.s, kb.r_min, T / n, n
            for k, seed in enumerate(seeds):
                tasks.append(_Task((a, b, k), model, filters, T, T / n, BURN * stretch[a, b] / kb.r_min, batches,
                                   group_seed(seed, alpha, sigma, w, m), n))
    tasks.sort(key=lambda t: -t.steps * (len(t.filters) + 1))
    return nu, design, best, theory, tasks, s, r_min, h, steps, stretch


def _check(alphas, sigma_range, n_sigma, m, w, sigma_design, window, horizon, seeds, batches, level):
    alphas = check_reals("alphas", alphas, lo=0.0, lo_open=True)
    lo, hi = check_sigma_range(sigma_range)
    if not hi > lo:
        raise ValueError(f"sigma_range must have sigma_max > sigma_min, got {short(sigma_range)}")
    n_sigma = check_int("n_sigma", n_sigma, lo=2, hi=101)
    m = check_int("m", m, lo=1, hi=M_MAX)
    w = check_real("w", w, lo=0.0, lo_open=True)
    if sigma_design is not None:
        sigma_design = check_real("sigma_design", sigma_design, lo=0.0, lo_open=True)
    window = check_real("window", window, lo=1.0)
    horizon, seeds, batches, level = _check_sampling(horizon, seeds, batches, level)
    sigmas = np.geomspace(lo, hi, n_sigma)
    sigmas[0], sigmas[-1] = lo, hi  # exact ends
    return alphas, sigmas, m, w, sigma_design, window, horizon, seeds, batches, level


def worst_case(
    alphas: Sequence[float] = FIG2_ALPHAS,
    *,
    sigma_range: tuple[float, float] = (2.0, 200.0),
    n_sigma: int = 5,
    m: int = 3,
    w: float = 3.0,
    filters: Sequence[str] = BASELINES,
    sigma_design: float | None = None,
    window: float = WINDOW,
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

    ``filters``: names from :data:`isl_core.baselines.BASELINES` (default all). ``sigma_design``: σ̄ of the
    mismatched Kalman–Bucy filter (default √(σ_min σ_max)); ``window``: the adaptive filter's W in steps.
    ``horizon`` (in 1/r_min), ``seeds``, ``batches``, ``level``, ``executor``, ``chunk``, ``workers`` and
    ``progress`` as in :func:`isl_core.sweep`: results do not depend on the executor or on chunking.
    """
    alphas, sigmas, m, w, sigma_design, window, horizon, seeds, batches, level = _check(
        alphas, sigma_range, n_sigma, m, w, sigma_design, window, horizon, seeds, batches, level)
    names = check_names(filters, "filters")
    chunk, workers = _check_execution(chunk, workers, progress)
    nu, design, best, theory, tasks, s, r_min, h, steps, stretch = _plan(
        alphas, sigmas, names, m, w, sigma_design, window, horizon, seeds, batches)
    prog = _Progress({t.key: t.steps * (len(t.filters) + 1) for t in tasks}, progress)
    out = _local(tasks, workers, prog) if executor is None else _remote(tasks, executor, chunk, prog)
    na, ns, nf = len(alphas), len(sigmas), len(names)
    sq = np.empty((na, ns, len(seeds) * batches, nf, m))
    counts = np.empty((na, ns, len(seeds) * batches))
    for (a, b, k), part, cnt in out:
        sq[a, b, k * batches:(k + 1) * batches] = part
        counts[a, b, k * batches:(k + 1) * batches] = cnt
    ratio, low, high = (np.empty((na, ns, nf, m)) for _ in range(3))
    for a in range(na):
        for b in range(ns):
            ratio[a, b], low[a, b], high[a, b] = ratio_interval(sq[a, b], counts[a, b], s[a, b], level)
    return WorstCaseTable(
        _frozen(alphas), _frozen(sigmas), names, m, w, horizon, seeds, batches, level, _frozen(ratio),
        _frozen(low), _frozen(high), _frozen(theory), _frozen(nu), _frozen(design), _frozen(best[0]),
        _frozen(best[1]), _frozen(r_min), _frozen(h), _frozen(steps, np.int64), _frozen(stretch))
