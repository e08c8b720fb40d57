"""One tuning rule for every family's knob: the minimax of the period statistic over the table's scenarios.

Every filter family that does not know σ(t) has a knob (:data:`FAMILIES`): paper A's ISL filter and the
model-aware one ν (ν/β = 2^ℓ), the adaptive and the variational-Bayes filters their memory W in sensor readings
(:mod:`isl_core.filters.adaptive`), the robust filter Huber's c and its memory (jointly: the clipping changes what the
estimate averages, so the best W depends on c), the IMM filter its switch probability per reading and its number of
modes (jointly: a denser grid needs less switching to follow a change). On a grid of each knob
(:class:`TuningGrids`), every variant rides in **one** scenario run per preset and seed — common random numbers:
the same noise for all — and the period statistic of :mod:`isl_core.scenario.periods` is taken per variant and cell
(preset × period). A variant's **tuning curve** is its statistic per cell against the knob; the family's knob is

    θ* = argmin_θ  max_cells ratio_θ(cell)                  (the minimax over the table's scenarios and periods)

and, as a reference, the **oracle-tuned** knob of a preset is argmin_θ max over that preset's periods (the best
tuning had one known the scenario). The rule is the same for every family; ties go to the first point of the grid.

The result (:class:`Tuning`) is reproducible bit for bit (fixed seeds; each run independent of the others and of
the threads that run it) and is cached on disk per (α, m, w, seeds, horizon, burn, presets, grids, the package's
sources digest) in :func:`cache_dir` — ``$ISL_CACHE_DIR``, else ``$XDG_CACHE_HOME/isl`` or ``~/.cache/isl`` — or
kept in memory if that is not writable (a read-only dashboard). Its ``origin`` says which.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..filters.base import SIGMA_RANGE, FilterSpec
from ..model import Model
from ..validate import check_int, check_real
from .base import Scenario
from .periods import Period, Worst, edge_times, per_seed, scenario_periods, seed_ratios, worst_from
from .presets import DEFAULT_RATE, PRESETS, at_rate, check_rate
from .run import ScenarioPlan, plan_scenario
from .tuning_cache import cache_dir, cache_key, load, save
from .variants import FAMILIES, TuningGrids, family_filter, grid_variants, paper_nu, variant_name

__all__ = [
    "FAMILIES",
    "SIGMA_RANGE",
    "Tuning",
    "TuningGrids",
    "cache_dir",
    "family_filter",
    "paper_nu",
    "plan_preset",
    "run_cells",
    "tune",
    "variant_name",
]


@dataclass(frozen=True)
class Tuning:
    """Every variant's period statistic per cell, from one run per preset and seed (module docstring).

    Filters (``names``, ``family``, ``knobs``): the clairvoyant reference, the Kalman–Bucy filter for σ(0), paper A's
    ISL filter at its table's ν (``family`` "isl_paper"; ν = β where table (A.31) has no value for this α), then every
    variant of every family. ``cells`` are (preset index, period); ``y`` (seeds, cells, filters, m) the seeds'
    contributions per coordinate (:func:`!isl_core.scenario.periods.per_seed`); a cell's figure is its worst
    coordinate's. Per preset: ``reading_time`` one reading in units of 1/r_min at σ(0) (W readings are
    W·reading_time), ``steps`` N, ``h``, ``substeps`` q (Euler steps per reading), and in ``scenarios`` its (σ(0),
    :class:`Scenario`) as run, at the reading ``rate`` (readings per 1/r_min at σ(0); None: a reading every step) with
    the step halved ``refine`` times below the coarsest that serves every variant (:func:`isl_core.scenario_grid`).
    ``origin`` says where it came from.
    """

    alpha: float
    m: int
    w: float
    seeds: tuple[int, ...]
    horizon: float
    burn: float
    grids: TuningGrids
    presets: tuple[str, ...]
    preset_labels: tuple[str, ...]
    cells: tuple[tuple[int, Period], ...]
    names: tuple[str, ...]
    family: tuple[str, ...]
    knobs: tuple[dict[str, Any], ...]  # numbers, but the paper row's ν label
    y: np.ndarray
    reading_time: tuple[float, ...]
    steps: tuple[int, ...]
    h: tuple[float, ...]
    seconds: float
    scenarios: tuple[tuple[float, Scenario], ...] = ()
    origin: str = ""
    rate: float | None = None
    refine: int = 0
    substeps: tuple[int, ...] = ()
    _stats: dict[float, Worst] = field(default_factory=dict, repr=False, compare=False)

    def stats(self, level: float = 0.95) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(ratio, low, high), each (filters, cells): the period statistic at the worst coordinate and its interval
        at ``level`` (:func:`!isl_core.scenario.periods.worst_from`)."""
        if level not in self._stats:
            self._stats[level] = worst_from(self.y, level)
        return self._stats[level][:3]

    def coordinate(self) -> np.ndarray:
        """The worst coordinate (0-based) per filter and cell (filters, cells)."""
        self.stats()
        return self._stats[0.95][3]

    def seed_ratios(self) -> np.ndarray:
        """Each seed's own worst-coordinate ratio (seeds, cells, filters)."""
        return seed_ratios(self.y)

    def preset_map(self) -> dict[str, tuple[str, float, Scenario]]:
        """The presets this tuning was computed over, as :func:`tune` takes them."""
        return {
            n: (lab, s0, sc) for n, lab, (s0, sc) in zip(self.presets, self.preset_labels, self.scenarios, strict=True)
        }

    def variants(self, family: str) -> np.ndarray:
        """Indices of the family's variants, in grid order."""
        return np.flatnonzero(np.array(self.family) == family)

    def preset_cells(self, preset: int) -> np.ndarray:
        """Indices of the cells of preset number ``preset``."""
        return np.array([c for c, (p, _) in enumerate(self.cells) if p == preset])

    def _argmin_max(self, family: str, cells: np.ndarray) -> int:
        idx = self.variants(family)
        worst = self.stats()[0][np.ix_(idx, cells)].max(axis=1)
        return int(idx[np.argmin(np.where(np.isnan(worst), np.inf, worst))])

    def minimax(self, family: str) -> int:
        """The family's tuned variant: the least, over its grid, of its largest ratio over every cell."""
        return self._argmin_max(family, np.arange(len(self.cells)))

    def on_edge(self, family: str) -> dict[str, str]:
        """The knobs of the family's minimax variant that sit at an end of their grid, knob → "lowest"/"highest" (a
        minimax on an edge is no bracketed optimum: :ref:`findings-grids`); empty when every knob is inside."""
        knob, points = self.knobs[self.minimax(family)], self.grids.points(family)
        out = {}
        for name, value in knob.items():
            values = sorted({p[name] for p in points})
            if len(values) > 1 and value in (values[0], values[-1]):
                out[name] = "lowest" if value == values[0] else "highest"
                if name == "memory" and value == values[0]:  # the grid starts at the limit of W: see the grids
                    out[name] += ": the hard limit W = 1" if value == 1.0 else ": W > 1 is its hard limit"
        return out

    def oracle(self, family: str, preset: int) -> int:
        """The family's best variant for one preset (oracle-tuned): least largest ratio over that preset's cells."""
        return self._argmin_max(family, self.preset_cells(preset))

    def filter(self, index: int, model: Model) -> FilterSpec:
        """The filter ``index`` (a variant) for ``model``, e.g. the tuned one of a family for a dashboard."""
        return family_filter(self.family[index], model, self.knobs[index], self.grids)

    def tuned_filters(self, model: Model) -> list[FilterSpec]:
        """Every family's minimax-tuned filter for ``model``, in :data:`FAMILIES` order."""
        return [self.filter(self.minimax(f), model) for f in FAMILIES]

    def grid_filters(self, model: Model) -> list[FilterSpec]:
        """Every variant for ``model``: given as ``grid_filters`` to :func:`isl_core.plan_scenario`, a run
        of a few filters gets the tuning's grid h — so W readings of a sensor read at every step span the time they
        spanned in the tuning (``reading_time``) — and, with the same seeds, its noise."""
        return [self.filter(j, model) for j in range(3, len(self.names))]


_MEMORY_CACHE: dict[str, Tuning] = {}


def plan_preset(
    alpha: float,
    m: int,
    w: float,
    sigma0: float,
    scenario: Scenario,
    horizon: float,
    burn: float,
    grids: TuningGrids,
    only: Sequence[tuple[str, Mapping[str, float]]] | None = None,
    refine: int = 0,
) -> tuple[ScenarioPlan, tuple[Period, ...]]:
    """The plan of one preset with every variant (or, ``only``, those of these (family, knob) pairs, on the grid of
    every variant: the same h and so, seed by seed, the same runs) and its periods; the step halved ``refine`` times
    (:func:`isl_core.scenario_grid`)."""
    model = Model.from_w(alpha, w, sigma0, m)
    periods = scenario_periods(scenario, horizon, burn=burn)
    every = [
        replace(family_filter(f, model, knob, grids), name=variant_name(f, knob)) for f, knob in grid_variants(grids)
    ]
    nu, _ = paper_nu(model, alpha, m, w)
    edges = edge_times(periods, horizon)
    if only is None:
        return plan_scenario(model, nu, scenario, horizon=horizon, extra=every, edges=edges, refine=refine), periods
    extra = [replace(family_filter(f, model, knob, grids), name=variant_name(f, knob)) for f, knob in only]
    plan = plan_scenario(
        model, nu, scenario, horizon=horizon, extra=extra, edges=edges, grid_filters=every, refine=refine
    )
    return plan, periods


def run_cells(
    plans: list[tuple[ScenarioPlan, tuple[Period, ...]]],
    seeds: tuple[int, ...],
    workers: int | None,
    progress: Callable[[float], None] | None,
) -> list[np.ndarray]:
    """Every (plan, seed) run on ``workers`` threads (the kernels release the GIL): per plan (with its periods, a pair
    of ``plans``) the seeds' contributions y (seeds, periods, filters, m) of :func:`per_seed`."""
    tasks = [(p, s) for p in range(len(plans)) for s in range(len(seeds))]
    cost = np.array([plans[p][0].N for p, _ in tasks], dtype=float)
    out = [np.empty((len(seeds), len(periods), len(plan.filters), plan.model.m)) for plan, periods in plans]

    def one(task: tuple[int, int]) -> None:
        p, s = task
        plan, periods = plans[p]
        run = plan.run(seeds[s])
        out[p][s] = per_seed(run.mse[None], run, periods)[0]

    done = 0.0
    with ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1) as pool:
        for t, _ in enumerate(pool.map(one, tasks)):  # in order: a failure propagates
            done += cost[t]
            if progress is not None:
                progress(done / cost.sum())
    return out


def _compute(
    alpha: float,
    m: int,
    w: float,
    presets: Mapping[str, tuple[str, float, Scenario]],
    seeds: tuple[int, ...],
    horizon: float,
    burn: float,
    grids: TuningGrids,
    workers: int | None,
    progress: Callable[[float], None] | None,
    refine: int,
) -> tuple[list[np.ndarray], list[ScenarioPlan], list[tuple[Period, ...]]]:
    """Every (preset, seed) run: y per preset, plans, periods."""
    plans = [plan_preset(alpha, m, w, s0, sc, horizon, burn, grids, refine=refine) for _, s0, sc in presets.values()]
    out = run_cells(plans, seeds, workers, progress)
    return out, [p for p, _ in plans], [per for _, per in plans]


def _assemble(alpha, m, w, presets, seeds, horizon, burn, grids, ys, plans, periods, seconds, rate) -> Tuning:
    cells = tuple((p, per) for p, pers in enumerate(periods) for per in pers)
    plan = plans[0]
    _, paper = paper_nu(plan.model, alpha, m, w)
    variants = grid_variants(grids)
    return Tuning(
        float(alpha),
        m,
        float(w),
        tuple(seeds),
        float(horizon),
        float(burn),
        grids,
        tuple(presets),
        tuple(v[0] for v in presets.values()),
        cells,
        tuple(f.name for f in plan.filters),
        ("clairvoyant", "kbf", "isl_paper", *(f for f, _ in variants)),
        ({}, {}, {"paper": paper}, *(k for _, k in variants)),
        np.concatenate(ys, axis=1),
        tuple(pl.memory_time(1.0) for pl in plans),
        tuple(pl.N for pl in plans),
        tuple(pl.h for pl in plans),
        float(seconds),
        tuple((s0, sc) for _, s0, sc in presets.values()),
        rate=rate,
        refine=plan.refine,
        substeps=tuple(pl.q for pl in plans),
    )


def tune(
    alpha: float = 1.0,
    *,
    m: int = 3,
    w: float = 3.0,
    presets: Mapping[str, tuple[str, float, Scenario]] | None = None,
    seeds: int = 32,
    horizon: float = 30.0,
    burn: float = 2.0,
    grids: TuningGrids = TuningGrids(),
    workers: int | None = None,
    progress: Callable[[float], None] | None = None,
    cache: bool = True,
    compute: bool = True,
    rate: float | None = DEFAULT_RATE,
    refine: int = 0,
) -> Tuning | None:
    """The tuning of every family over ``presets`` (default the table's, :data:`!isl_core.scenario.presets.PRESETS`) for
    paper A's model with this α (β = w√(2α), A.25): seeds 0 … ``seeds`` − 1, ``horizon`` in 1/r_min at σ(0), the
    periods of :func:`isl_core.scenario_periods` after ``burn``; on ``workers`` threads (default: the
    CPUs). Read from the cache when it holds these inputs (``cache``), else computed (and cached; module docstring) —
    or, with ``compute`` False, None.

    Parameters
    ----------
    alpha : float, default 1.0
        The model's α (paper A's model, β = w√(2α)).
    presets : mapping, optional
        name → (label, σ(0), :class:`Scenario`) (default :data:`!PRESETS`).
    seeds : int
        Independent noises per preset, seeds 0 … ``seeds`` − 1.
    grids : TuningGrids
        The knobs' grids.
    cache, compute : bool
        Read and write the cache; compute what is not cached.
    rate : float or None, default :data:`!isl_core.scenario.presets.DEFAULT_RATE`
        Sensor readings per 1/r_min at σ(0), the same for every filter (:ref:`reading-rate`); None: a reading every
        step of the Euler grid (whose step then sets the rate).
    refine : int, default 0
        Halvings of the Euler step below the coarsest that serves every variant (the readings unchanged).
    m, w, horizon, burn, workers, progress
        As described above.

    Returns
    -------
    Tuning or None
        Every family's tuning curves and minimax knob; None when not cached and ``compute`` is False.

    Examples
    --------
    >>> from isl_core import tune
    >>> tune(1.0, seeds=2, horizon=5.0, cache=False, compute=False) is None  # neither cached nor computed
    True
    """
    alpha = check_real("alpha", alpha, lo=0.0, lo_open=True)
    m = check_int("m", m, lo=1, hi=6)
    w = check_real("w", w, lo=0.0, lo_open=True)
    seed_ids = tuple(range(check_int("seeds", seeds, lo=2, hi=10_000)))
    horizon = check_real("horizon", horizon, lo=0.0, lo_open=True)
    rate = check_rate(rate)
    presets = at_rate(PRESETS if presets is None else presets, rate)
    if not presets or not isinstance(grids, TuningGrids):
        raise ValueError(
            "presets must name at least one scenario and grids must be an isl_core.scenario.tuning.TuningGrids"
        )
    key = cache_key(alpha, m, w, seed_ids, horizon, burn, presets, grids, refine)
    digest = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:20]
    path = cache_dir() / f"tuning-{digest}.npz"
    span = (
        f"minimax over {len(presets)} presets × their periods of the period statistic (isl scenario --tune), "
        f"seeds {seed_ids[0]}–{seed_ids[-1]}, horizon {horizon:g}/r_min, "
        + (f"{rate:g} readings per 1/r_min" if rate is not None else "a reading every Euler step")
    )
    if cache and digest in _MEMORY_CACHE:
        return _MEMORY_CACHE[digest]
    found = load(path, key) if cache else None
    if found is not None:
        y, seconds = found
        plans = [
            plan_preset(alpha, m, w, s0, sc, horizon, burn, grids, refine=refine) for _, s0, sc in presets.values()
        ]
        cells = [len(per) for _, per in plans]
        ys = np.split(y, np.cumsum(cells)[:-1], axis=1)
        res = _assemble(
            alpha,
            m,
            w,
            presets,
            seed_ids,
            horizon,
            burn,
            grids,
            ys,
            [p for p, _ in plans],
            [per for _, per in plans],
            seconds,
            rate,
        )
        return _named(res, f"{span}; read from the cache {path} (computed in {seconds:.0f} s)", digest, cache)
    if not compute:
        return None
    start = time.perf_counter()
    ys, plan_list, periods = _compute(alpha, m, w, presets, seed_ids, horizon, burn, grids, workers, progress, refine)
    res = _assemble(
        alpha, m, w, presets, seed_ids, horizon, burn, grids, ys, plan_list, periods, time.perf_counter() - start, rate
    )
    saved = cache and save(path, res.y, res.seconds, key)
    where = f"cached in {path}" if saved else "kept in memory (the cache is not writable)"
    return _named(res, f"{span}; computed now in {res.seconds:.0f} s, {where}", digest, cache)


def _named(res: Tuning, origin: str, digest: str, cache: bool) -> Tuning:
    res = replace(res, origin=origin, _stats={})
    if cache:
        _MEMORY_CACHE[digest] = res
    return res
