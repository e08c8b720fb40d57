"""The runs a tuning is made of: one plan per preset with every variant of every family on one grid, one run per
(plan, seed) on local threads, and each run's period statistic per cell (:func:`isl_core.tune`, and the held-out
check of :func:`!isl_core.scenario.heldout.held_out`, which runs a few of the variants on the same grid).

Every run depends on its plan and seed only, never on the threads that run it or their order, so a tuning is
reproducible bit for bit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

import numpy as np

from ..model import Model
from ..requests import Execution
from ..validate import short
from .base import Scenario
from .periods import Period, edge_times, per_seed, scenario_periods
from .run import ScenarioPlan, plan_scenario
from .variants import TuningGrids, family_filter, grid_variants, paper_nu, variant_name

__all__ = ["local_threads", "plan_preset", "run_cells"]


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


def local_threads(execution: Execution | None) -> Execution:
    """``execution`` (default ``Execution()``) if it runs on local threads; a ``ValueError`` if it names an
    ``executor``: the runs share their plans in memory, so they run on this process's threads only."""
    execution = Execution() if execution is None else execution
    if not isinstance(execution, Execution):
        raise ValueError(f"execution must be an isl_core.Execution or None, got {short(execution)}")
    if execution.executor is not None:
        raise ValueError(
            "execution.executor must be None: a tuning runs on local threads (execution.workers), "
            f"got {short(execution.executor)}"
        )
    return execution


def run_cells(
    plans: Sequence[tuple[ScenarioPlan, tuple[Period, ...]]], seeds: Sequence[int], execution: Execution
) -> list[np.ndarray]:
    """Every (plan, seed) run on ``execution.n_workers`` threads (the kernels release the GIL), its progress told to
    ``execution.progress``: per plan (with its periods, a pair of ``plans``) the seeds' contributions y (seeds,
    periods, filters, m) of :func:`!isl_core.scenario.periods.per_seed`."""
    tasks = [(p, s) for p in range(len(plans)) for s in range(len(seeds))]
    cost = np.array([plans[p][0].N for p, _ in tasks], dtype=float)
    out = [np.empty((len(seeds), len(periods), len(plan.filters), plan.model.m)) for plan, periods in plans]

    def one(task: tuple[int, int]) -> None:
        p, s = task
        plan, periods = plans[p]
        run = plan.run(seeds[s])
        out[p][s] = per_seed(run.mse[None], run, periods)[0]

    done, progress = 0.0, execution.progress
    with ThreadPoolExecutor(max_workers=execution.n_workers) as pool:
        for t, _ in enumerate(pool.map(one, tasks)):  # in order: a failure propagates
            done += cost[t]
            if progress is not None:
                progress(done / cost.sum())
    return out
