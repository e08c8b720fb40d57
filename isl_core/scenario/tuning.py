"""The tuning as a job: :func:`tune` takes a request — the model (α, m, w), the presets, what to sample
(:class:`isl_core.Sampling`: the seeds, the horizon, the burn-in) and how to run (:class:`isl_core.Execution`: the
threads, the progress, the cache) — and returns the :class:`Tuning` of every family (the minimax rule of
:mod:`isl_core.scenario.minimax`), from its runs (:mod:`isl_core.scenario.tasks`).

The result is reproducible bit for bit (fixed seeds; each run independent of the others and of the threads that run
it) and is cached on disk per (α, m, w, seeds, horizon, burn, presets, grids, the package's sources digest) in
:func:`cache_dir` — ``$ISL_CACHE_DIR``, else ``$XDG_CACHE_HOME/isl`` or ``~/.cache/isl`` — or kept in memory if that is
not writable (a read-only dashboard). Its ``origin`` says which.
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..filters.base import SIGMA_RANGE
from ..requests import Execution, Sampling
from ..validate import check_int, check_real, short
from .base import Scenario
from .grid import MAX_REFINE
from .minimax import Tuning
from .periods import Period
from .presets import DEFAULT_RATE, PRESETS, at_rate, check_rate
from .run import ScenarioPlan
from .tasks import local_threads, plan_preset, run_cells
from .tuning_cache import cache_dir, cache_key, load, save
from .variants import FAMILIES, TuningGrids, family_filter, grid_variants, paper_nu, variant_name

__all__ = [
    "FAMILIES",
    "SIGMA_RANGE",
    "TUNING_SAMPLING",
    "Tuning",
    "TuningGrids",
    "cache_dir",
    "family_filter",
    "paper_nu",
    "tune",
    "tuning_sampling",
    "variant_name",
]

#: What a tuning samples by default: seeds 0 … 31, a horizon of 30/r_min at σ(0), the first 2/r_min left out where σ
#: does not change (the shipped tunings' rule, :func:`isl_core.scenario.shipped.rule`)
TUNING_SAMPLING = Sampling.first(32, horizon=30.0, burn=2.0)

_MEMORY_CACHE: dict[str, Tuning] = {}

Presets = Mapping[str, tuple[str, float, Scenario]]


@dataclass(frozen=True)
class _Job:
    """One tuning's inputs, checked: the model (α, m, w), the presets at the reading ``rate``, the sampling, the
    grids and the step's ``refine``."""

    alpha: float
    m: int
    w: float
    presets: Presets
    sampling: Sampling
    grids: TuningGrids
    rate: float | None
    refine: int

    def plans(self) -> list[tuple[ScenarioPlan, tuple[Period, ...]]]:
        """Every preset's plan with every variant, and its periods."""
        s = self.sampling
        return [
            plan_preset(self.alpha, self.m, self.w, s0, sc, s.horizon, s.burn, self.grids, refine=self.refine)
            for _, s0, sc in self.presets.values()
        ]

    def key(self) -> dict[str, Any]:
        """What the cache keys this tuning by (:func:`!isl_core.scenario.tuning_cache.cache_key`)."""
        s = self.sampling
        return cache_key(self.alpha, self.m, self.w, s.seeds, s.horizon, s.burn, self.presets, self.grids, self.refine)

    def span(self) -> str:
        """The tuning's inputs in words, for its ``origin``."""
        seeds, rate = self.sampling.seeds, self.rate
        return (
            f"minimax over {len(self.presets)} presets × their periods of the period statistic (isl scenario --tune), "
            f"seeds {seeds[0]}–{seeds[-1]}, horizon {self.sampling.horizon:g}/r_min, "
            + (f"{rate:g} readings per 1/r_min" if rate is not None else "a reading every Euler step")
        )


def _assemble(
    job: _Job, plans: list[tuple[ScenarioPlan, tuple[Period, ...]]], ys: list[np.ndarray], seconds: float
) -> Tuning:
    """The :class:`Tuning` of ``job`` from its ``plans`` (with their periods) and their runs' contributions ``ys``
    (one array per plan, seeds × periods × filters × m), computed in ``seconds``."""
    plan = plans[0][0]
    _, paper = paper_nu(plan.model, job.alpha, job.m, job.w)
    variants = grid_variants(job.grids)
    presets = job.presets.values()
    return Tuning(
        job.alpha,
        job.m,
        job.w,
        job.sampling.seeds,
        job.sampling.horizon,
        job.sampling.burn,
        job.grids,
        tuple(job.presets),
        tuple(label for label, _, _ in presets),
        tuple((p, per) for p, (_, pers) in enumerate(plans) for per in pers),
        tuple(f.name for f in plan.filters),
        ("clairvoyant", "kbf", "isl_paper", *(f for f, _ in variants)),
        ({}, {}, {"paper": paper}, *(k for _, k in variants)),
        np.concatenate(ys, axis=1),
        tuple(pl.memory_time(1.0) for pl, _ in plans),
        tuple(pl.N for pl, _ in plans),
        tuple(pl.h for pl, _ in plans),
        float(seconds),
        tuple((s0, sc) for _, s0, sc in presets),
        rate=job.rate,
        refine=plan.refine,
        substeps=tuple(pl.q for pl, _ in plans),
    )


def tuning_sampling(sampling: Sampling | None) -> Sampling:
    """``sampling`` (default :data:`TUNING_SAMPLING`) if a tuning can take it: at least two seeds, an interval over
    them; else a ``ValueError`` that says so."""
    sampling = TUNING_SAMPLING if sampling is None else sampling
    if not isinstance(sampling, Sampling):
        raise ValueError(f"sampling must be an isl_core.Sampling or None, got {short(sampling)}")
    if sampling.n_seeds < 2:
        raise ValueError(f"sampling.seeds must hold at least 2 seeds (an interval over them), got {sampling.seeds}")
    return sampling


def _job(
    alpha: float,
    m: int,
    w: float,
    presets: Presets | None,
    sampling: Sampling | None,
    grids: TuningGrids,
    rate: float | None,
    refine: int,
) -> _Job:
    """The checked inputs of :func:`tune` (its parameters)."""
    sampling = tuning_sampling(sampling)
    rate = check_rate(rate)
    presets = at_rate(PRESETS if presets is None else presets, rate)
    if not presets or not isinstance(grids, TuningGrids):
        raise ValueError(
            "presets must name at least one scenario and grids must be an isl_core.scenario.tuning.TuningGrids"
        )
    return _Job(
        check_real("alpha", alpha, lo=0.0, lo_open=True),
        check_int("m", m, lo=1, hi=6),
        check_real("w", w, lo=0.0, lo_open=True),
        presets,
        sampling,
        grids,
        rate,
        check_int("refine (halvings of the step)", refine, lo=0, hi=MAX_REFINE),
    )


def tune(
    alpha: float = 1.0,
    *,
    m: int = 3,
    w: float = 3.0,
    presets: Presets | None = None,
    sampling: Sampling | None = None,
    execution: Execution | None = None,
    grids: TuningGrids = TuningGrids(),
    compute: bool = True,
    rate: float | None = DEFAULT_RATE,
    refine: int = 0,
) -> Tuning | None:
    """The tuning of every family over ``presets`` (default the table's, :data:`!isl_core.scenario.presets.PRESETS`) for
    paper A's model with this α (β = w√(2α), A.25): one run per preset and seed of ``sampling``, ``horizon`` in
    1/r_min at σ(0), the periods of :func:`isl_core.scenario_periods` after ``burn``. Read from the cache when it holds
    these inputs (``execution.cache``), else computed on ``execution``'s threads (and cached; module docstring) — or,
    with ``compute`` False, None.

    Parameters
    ----------
    alpha : float, default 1.0
        The model's α (paper A's model, β = w√(2α)).
    m, w : int, float
        The state dimension and the stationary std of X_m.
    presets : mapping, optional
        name → (label, σ(0), :class:`Scenario`) (default :data:`!PRESETS`).
    sampling : Sampling, optional
        The seeds (at least two: independent noises per preset), ``horizon`` and ``burn`` (units of 1/r_min at σ(0));
        default :data:`TUNING_SAMPLING` (seeds 0 … 31, horizon 30, burn 2). Its ``batches`` and ``level`` do not
        enter a tuning.
    execution : Execution, optional
        ``workers`` threads (default: the CPUs), ``progress``, ``cache`` (read and write the cache). Its
        ``executor`` must be None: the runs share their plans in this process.
    grids : TuningGrids
        The knobs' grids.
    compute : bool, default True
        Compute what is not cached.
    rate : float or None, default :data:`!isl_core.scenario.presets.DEFAULT_RATE`
        Sensor readings per 1/r_min at σ(0), the same for every filter (:ref:`reading-rate`); None: a reading every
        step of the Euler grid (whose step then sets the rate).
    refine : int, default 0
        Halvings of the Euler step below the coarsest that serves every variant (the readings unchanged).

    Returns
    -------
    Tuning or None
        Every family's tuning curves and minimax knob; None when not cached and ``compute`` is False.

    Examples
    --------
    >>> from isl_core import Execution, Sampling, tune
    >>> few = Sampling.first(2, horizon=5.0, burn=2.0)
    >>> tune(1.0, sampling=few, execution=Execution(cache=False), compute=False) is None  # neither cached nor computed
    True
    """
    job = _job(alpha, m, w, presets, sampling, grids, rate, refine)
    execution = local_threads(execution)
    key = job.key()
    digest = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:20]
    path = cache_dir() / f"tuning-{digest}.npz"
    if execution.cache and digest in _MEMORY_CACHE:
        return _MEMORY_CACHE[digest]
    found = load(path, key) if execution.cache else None
    if found is not None:
        y, seconds = found
        plans = job.plans()
        ys = np.split(y, np.cumsum([len(per) for _, per in plans])[:-1], axis=1)
        res = _assemble(job, plans, ys, seconds)
        origin = f"{job.span()}; read from the cache {path} (computed in {seconds:.0f} s)"
        return _named(res, origin, digest, execution.cache)
    if not compute:
        return None
    start = time.perf_counter()
    plans = job.plans()
    res = _assemble(job, plans, run_cells(plans, job.sampling.seeds, execution), time.perf_counter() - start)
    saved = execution.cache and save(path, res.y, res.seconds, key)
    where = f"cached in {path}" if saved else "kept in memory (the cache is not writable)"
    return _named(res, f"{job.span()}; computed now in {res.seconds:.0f} s, {where}", digest, execution.cache)


def _named(res: Tuning, origin: str, digest: str, cache: bool) -> Tuning:
    res = replace(res, origin=origin, _stats={})
    if cache:
        _MEMORY_CACHE[digest] = res
    return res
