"""Sweeps of the RMSE ratio š_i/s_i over (α, σ, ν) — paper A's Fig. 2 (A.25, A.29–A.30, :ref:`empirical-rmse`).

For every (α, σ) with β = w·√(2α) (A.25) — or one β for every α (``beta=``: any model, α = 0 included) — and every
seed, ONE long run carries the optimal Kalman–Bucy filter and the ISL filters of all ν together (common random
numbers), accumulating squared errors on the fly (:func:`isl_core.simulate_rmse`); this unit of work is a *group*,
an :class:`isl_core.jobs.Task`. Groups run through :func:`isl_core.jobs.run`: in parallel on a local thread pool (the
kernel releases the GIL), on any ``concurrent.futures.Executor`` or on a ``dask.distributed.Client`` (optional extra
``isl[dask]``), in chunks of groups.

Conventions, all documented choices:

* step h of a group: the :ref:`step-size` rule over all filters of the group (:func:`isl_core.step_size`), so one
  grid serves every ν. Length: ``horizon`` and a burn-in (default SWEEP_BURN = 10) are counted in units of the
  settling time of the group's slowest filter (:func:`isl_core.grid.settling_rate`, B.46) — 1/r_min unless a filter
  settles more than 10 % slower (an ISL filter at small ν: up to ≈ 6× at m = 3); then the group's run is lengthened by
  ``stretch = r_min / rate`` so that every filter has forgotten its start (by e^{-10}) and averages over the same
  number of its own settling times. ``stretch`` is reported per group.
* seed of a group: derived from ``(seed, α, σ, w, m)`` by ``numpy.random.SeedSequence`` — it does not depend
  on the other α, σ of the sweep, on chunking or on the executor, so results are identical across them.
* confidence interval: batch means. Each run is cut into ``batches`` equal batches (each ≥ 100/r_min long by
  default, ≫ the error's correlation time 1/r_min near the best ν); with n_b = batches × seeds batch
  mean squared errors y_b, the pooled MSE ȳ has the Student interval ``ȳ ± t_{n_b−1}·sd(y)/√n_b``, mapped
  through the monotone ``√(·)/s_i``. Where the ISL filter loses lock (very small ν) its errors decorrelate
  slowly and the interval is too narrow — a known limit of batch means.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from ._engine import freeze
from .bounds import BOUNDS
from .filters.base import FilterSpec
from .filters.isl import isl_filter, model_aware_isl
from .filters.kalman import optimal_kbf
from .grid import MAX_STEPS, settling_rate, step_size
from .jobs import Task, TaskResult, run
from .model import Model
from .paper import FIG2_ALPHAS, FIG2_NU_OVER_BETA, FIG2_SIGMAS
from .requests import SWEEP_BURN, Execution, Sampling
from .riccati import KalmanBucy, kalman_bucy
from .theory import predicted_ratios_grid
from .validate import check_reals, short

__all__ = [
    "SWEEP_BURN",
    "SweepResult",
    "check_requests",
    "group_length",
    "group_seed",
    "pooled_ratios",
    "ratio_interval",
    "sweep",
]


def group_seed(seed: int, alpha: float, sigma: float, w: float, m: int, *, beta: float | None = None) -> int:
    """Seed of one (α, σ) group, from the user's seed and the group's own parameters only (``beta``: a sweep at a
    fixed β instead of a fixed w; its seeds differ from every w-sweep's)."""
    bits = [int(np.float64(x).view(np.uint64)) for x in (alpha, sigma, w if beta is None else beta)]
    tag = [] if beta is None else [1]
    return int(np.random.SeedSequence([seed, *bits, m, *tag]).generate_state(1, np.uint64)[0])


def pooled_ratios(
    out: Sequence[TaskResult],
    s: np.ndarray,
    level: float,
    n_runs: int,
    batches: int,
    nf: int,
    columns: Sequence[Sequence[int]] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every group's pooled ratios and intervals, ``(ratio, low, high)`` of shape (α, σ, filter, i), from the
    records of :func:`isl_core.jobs.run` keyed ``(a, b, k)`` (α, σ, seed index) with ``batches`` batches each.

    ``s`` (α, σ, m): the optimal RMSEs; ``columns[a]``: where a record's filters go among the ``nf`` (default:
    all of them in order; a filter not simulated at some α stays nan).
    """
    na, ns, m = np.shape(s)
    sq = np.full((na, ns, n_runs * batches, nf, m), np.nan)
    counts = np.empty((na, ns, n_runs * batches))
    for r in out:
        a, b, k = cast("tuple[int, int, int]", r.key)
        rows = slice(k * batches, (k + 1) * batches)
        if columns is None:
            sq[a, b, rows] = r.sq
        else:
            sq[a, b, rows][:, list(columns[a])] = r.sq
        counts[a, b, rows] = r.counts
    ratio, low, high = (np.empty((na, ns, nf, m)) for _ in range(3))
    for a in range(na):
        for b in range(ns):
            ratio[a, b], low[a, b], high[a, b] = ratio_interval(sq[a, b], counts[a, b], s[a, b], level)
    return ratio, low, high


def ratio_interval(
    sq: np.ndarray, counts: np.ndarray, s: np.ndarray, level: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pooled ratio √(Σsq/Σn)/s and its batch-means interval at ``level`` (module docstring).

    ``sq`` (n_b, ..., m) squared-error sums per batch, ``counts`` (n_b,) steps per batch, ``s`` (m,).
    Returns ``(ratio, low, high)`` with the shape of ``sq[0]``.
    """
    from scipy.stats import t as student_t  # lazy: scipy.stats costs ~1 s to import

    counts = np.asarray(counts, dtype=float).reshape((-1,) + (1,) * (sq.ndim - 1))
    y = sq / counts
    pooled = sq.sum(axis=0) / counts.sum()
    n_b = sq.shape[0]
    half = student_t.ppf(0.5 + level / 2.0, n_b - 1) * y.std(axis=0, ddof=1) / math.sqrt(n_b)
    return np.sqrt(pooled) / s, np.sqrt(np.maximum(pooled - half, 0.0)) / s, np.sqrt(pooled + half) / s


@dataclass(frozen=True)
class SweepResult:
    """Simulated and predicted ratios on the grid ``alphas × sigmas × nu_over_beta`` (coordinates last).

    ``ratio`` (nα, nσ, nν, m) simulated š_i/s_i (A.30) pooled over seeds and batches, with the interval
    ``[ratio_low, ratio_high]`` at ``level``; nan where a filter diverged. ``kbf_ratio`` (nα, nσ, m) the optimal
    filter's own measured ratio (≈ 1) with ``kbf_low``, ``kbf_high``. ``theory`` (nα, nσ, nν, m) the
    statistical-linearization prediction (B.48, :ref:`linearized-covariance`). ``s`` (nα, nσ, m) optimal RMSE;
    ``r_min``, ``h``, ``steps`` (nα, nσ) per group and seed; ``stretch`` (nα, nσ) the group's lengthening: burn-in
    ``burn·stretch/r_min`` then an average over ``horizon·stretch/r_min`` (``burn``: the sampling's burn-in).
    ``model_aware``: the ISL filter propagated with A instead of A0. ``beta``: the one β of every α (a sweep of any
    model), else None and β follows from ``w`` (A.25; ``w`` is nan in a fixed-β sweep).
    """

    alphas: np.ndarray
    sigmas: np.ndarray
    nu_over_beta: np.ndarray
    m: int
    w: float
    horizon: float
    seeds: tuple[int, ...]
    batches: int
    level: float
    ratio: np.ndarray
    ratio_low: np.ndarray
    ratio_high: np.ndarray
    kbf_ratio: np.ndarray
    kbf_low: np.ndarray
    kbf_high: np.ndarray
    theory: np.ndarray
    s: np.ndarray
    r_min: np.ndarray
    h: np.ndarray
    steps: np.ndarray = field(repr=False)
    stretch: np.ndarray = field(repr=False)
    model_aware: bool = False
    beta: float | None = None
    burn: float = SWEEP_BURN

    @property
    def betas(self) -> np.ndarray:
        """β per α: w·√(2α) (A.25), or the sweep's fixed β."""
        if self.beta is not None:
            return np.full(len(self.alphas), self.beta)
        return self.w * np.sqrt(2.0 * self.alphas)

    @property
    def nus(self) -> np.ndarray:
        """ν (nα, nν) = (ν/β)·β."""
        return cast("np.ndarray", self.betas[:, None] * self.nu_over_beta[None, :])

    def records(self) -> list[dict[str, Any]]:
        """One flat row per (α, σ, ν, i) — for CSV/JSON export."""
        rows = []
        for a, alpha in enumerate(self.alphas):
            for b, sigma in enumerate(self.sigmas):
                for n, nob in enumerate(self.nu_over_beta):
                    for i in range(self.m):
                        rows.append(
                            {
                                "alpha": float(alpha),
                                "beta": float(self.betas[a]),
                                "sigma": float(sigma),
                                "nu_over_beta": float(nob),
                                "nu": float(self.nus[a, n]),
                                "i": i + 1,
                                "ratio": float(self.ratio[a, b, n, i]),
                                "ratio_low": float(self.ratio_low[a, b, n, i]),
                                "ratio_high": float(self.ratio_high[a, b, n, i]),
                                "theory": float(self.theory[a, b, n, i]),
                                "kbf_ratio": float(self.kbf_ratio[a, b, i]),
                                "kbf_low": float(self.kbf_low[a, b, i]),
                                "kbf_high": float(self.kbf_high[a, b, i]),
                                "s": float(self.s[a, b, i]),
                                "r_min": float(self.r_min[a, b]),
                                "h": float(self.h[a, b]),
                                "burn_in_over_r_min": self.burn * float(self.stretch[a, b]),
                                "window_over_r_min": self.horizon * float(self.stretch[a, b]),
                            }
                        )
        return rows


@dataclass(frozen=True)
class _Plan:
    """A sweep's tasks (most expensive first) and, per (α, σ), what the results are measured against."""

    tasks: list[Task]
    s: np.ndarray  # (nα, nσ, m) the optimal RMSEs
    r_min: np.ndarray
    h: np.ndarray
    steps: np.ndarray
    stretch: np.ndarray
    theory: np.ndarray  # (nα, nσ, nν, m)


def _plan(
    alphas: np.ndarray,
    sigmas: np.ndarray,
    nob: np.ndarray,
    m: int,
    w: float,
    sampling: Sampling,
    model_aware: bool = False,
    beta: float | None = None,
) -> _Plan:
    """Every group's task and per-(α, σ) s, r_min, h, steps, stretch and the theory grid."""
    shape = (len(alphas), len(sigmas))
    s, r_min, h, steps = np.empty((*shape, m)), np.empty(shape), np.empty(shape), np.empty(shape, dtype=np.int64)
    stretch = np.empty(shape)
    theory = np.empty((*shape, len(nob), m))
    tasks = []
    for a, alpha in enumerate(alphas):
        for b, sigma in enumerate(sigmas):
            model = Model.from_w(alpha, w, sigma, m) if beta is None else Model(alpha, beta, sigma, m)
            kb = kalman_bucy(model)
            isl = model_aware_isl if model_aware else isl_filter
            filters = (optimal_kbf(model, kb), *(isl(model, model.beta * x) for x in nob))
            T, n, stretch[a, b] = group_length(model, kb, filters, sampling.horizon, sampling.burn)
            s[a, b], r_min[a, b], h[a, b], steps[a, b] = kb.s, kb.r_min, T / n, n
            theory[a, b] = predicted_ratios_grid(model, model.beta * nob, damp=model.alpha if model_aware else None)
            burn = sampling.burn * stretch[a, b] / kb.r_min
            for k, seed in enumerate(sampling.seeds):
                key = group_seed(seed, alpha, sigma, w, m, beta=beta)
                tasks.append(Task((a, b, k), model, filters, T, T / n, burn, sampling.batches, key, n))
    tasks.sort(key=lambda t: -t.cost)
    return _Plan(tasks, s, r_min, h, steps, stretch, theory)


def group_length(
    model: Model, kb: KalmanBucy, filters: Sequence[FilterSpec], horizon: float, burn: float = SWEEP_BURN
) -> tuple[float, int, float]:
    """``(T, N, stretch)`` of one group: ``burn`` plus ``horizon``, both in units of the slowest filter's settling
    time ``stretch/r_min`` (module docstring), on the step of :func:`isl_core.step_size`; ``ValueError`` past the
    step cap naming the group and the setting to lower."""
    stretch = kb.r_min / settling_rate(model, kb, filters)
    T = (burn + horizon) * stretch / kb.r_min
    steps = T / step_size(model, kb, filters)
    if not steps <= MAX_STEPS:
        raise ValueError(
            f"horizon = {horizon:g} needs {steps:,.0f} steps at alpha = {model.alpha:g}, "
            f"sigma = {model.sigma:g} (lengthened ×{stretch:.3g} for the slowest filter), over the limit "
            f"of {MAX_STEPS:,}; shorten horizon"
        )
    return T, math.ceil(steps - 1e-9), stretch


def sweep(
    alphas: Sequence[float] | np.ndarray = FIG2_ALPHAS,
    sigmas: Sequence[float] | np.ndarray = FIG2_SIGMAS,
    nu_over_beta: Sequence[float] | np.ndarray = FIG2_NU_OVER_BETA,
    *,
    m: int = 3,
    w: float = 3.0,
    beta: float | None = None,
    model_aware: bool = False,
    sampling: Sampling | None = None,
    execution: Execution | None = None,
) -> SweepResult:
    """Simulate š_i/s_i on the grid ``alphas × sigmas × nu_over_beta`` (paper A's Fig. 2 by default).

    β = w·√(2α) (A.25). ``sampling`` (:class:`isl_core.Sampling`): the seeds, and per seed a burn-in then an average
    over ``horizon``, both in units of the group's settling time, cut into batches for the intervals at ``level``.
    ``execution`` (:class:`isl_core.Execution`): a local pool of threads, a ``concurrent.futures.Executor`` or a
    ``dask.distributed.Client``; results do not depend on it. Its ``progress(fraction)`` is called as work
    completes (from worker threads, one call at a time); an exception raised from it cancels the sweep and
    propagates. ``model_aware``: sweep the model-aware ISL filter (propagation with A, :ref:`model-aware-isl`)
    instead of paper A's (A0); its theory is :ref:`linearized-covariance` with A. ``beta``: sweep any model — the same β
    at every α (α = 0 allowed: paper B's model) instead of paper A's β = w·√(2α); ``w`` is then ignored.

    Parameters
    ----------
    alphas, sigmas : sequence of float
        The grid of α (> 0; ≥ 0 with ``beta``) and σ (default paper A's Fig. 2).
    nu_over_beta : sequence of float
        The ISL tunings ν/β.
    m, w : int, float
        State dimension; stationary std of X_m (β = w√(2α)).
    beta, model_aware : float or None, bool
        As described above.
    sampling : Sampling, optional
        Default ``Sampling()``: seeds (0, 1), horizon 1000, burn-in SWEEP_BURN, 10 batches per seed, level 0.95.
    execution : Execution, optional
        Default ``Execution()``: local threads, one per CPU.

    Returns
    -------
    SweepResult
        ``ratio`` (nα, nσ, nν, m) of the ISL filters with intervals, ``kbf_ratio`` of the optimal filter, ``theory``
        the predicted ratios, ``s`` the optimal RMSEs.

    Examples
    --------
    >>> from isl_core import Execution, Sampling, sweep
    >>> res = sweep([1.0], [20.0], [1.0], sampling=Sampling((0,), 20.0, batches=2), execution=Execution(workers=1))
    >>> res.ratio.shape, res.kbf_ratio.shape, res.theory.shape
    ((1, 1, 1, 3), (1, 1, 3), (1, 1, 1, 3))
    """
    if beta is None:
        alphas = BOUNDS.alpha.reals(alphas, "alphas")
        if not np.all(alphas > 0.0):
            raise ValueError(
                f"alphas must be a non-empty sequence of numbers (a finite number > 0), got {short(alphas)}"
            )
        w = BOUNDS.w.real(w)
    else:
        alphas = BOUNDS.alpha.reals(alphas, "alphas")
        beta = BOUNDS.beta.real(beta)
        w = math.nan
    sigmas = BOUNDS.sigma.reals(sigmas, "sigmas")
    nob = check_reals("nu_over_beta", nu_over_beta, lo=0.0, lo_open=True)
    m = BOUNDS.m.whole(m)
    sampling, execution = check_requests(sampling, execution)
    if not isinstance(model_aware, bool):
        raise ValueError(f"model_aware must be True or False, got {short(model_aware)}")
    plan = _plan(alphas, sigmas, nob, m, w, sampling, model_aware, beta)
    out = run(plan.tasks, execution)
    ratio, low, high = pooled_ratios(out, plan.s, sampling.level, sampling.n_seeds, sampling.batches, len(nob) + 1)
    return SweepResult(
        freeze(alphas),
        freeze(sigmas),
        freeze(nob),
        m,
        w,
        sampling.horizon,
        sampling.seeds,
        sampling.batches,
        sampling.level,
        freeze(ratio[:, :, 1:]),
        freeze(low[:, :, 1:]),
        freeze(high[:, :, 1:]),
        freeze(ratio[:, :, 0]),
        freeze(low[:, :, 0]),
        freeze(high[:, :, 0]),
        freeze(plan.theory),
        freeze(plan.s),
        freeze(plan.r_min),
        freeze(plan.h),
        freeze(plan.steps, np.int64),
        freeze(plan.stretch),
        model_aware,
        beta,
        sampling.burn,
    )


def check_requests(sampling: object, execution: object) -> tuple[Sampling, Execution]:
    """``sampling`` and ``execution`` (None: the defaults), or ``ValueError`` unless they are a
    :class:`isl_core.Sampling` and an :class:`isl_core.Execution` (each checked its own fields when it was made)."""
    sampling = Sampling() if sampling is None else sampling
    execution = Execution() if execution is None else execution
    if not isinstance(sampling, Sampling):
        raise ValueError(f"sampling must be an isl_core.Sampling, got {short(sampling)}")
    if not isinstance(execution, Execution):
        raise ValueError(f"execution must be an isl_core.Execution, got {short(execution)}")
    return sampling, execution
