"""What each filter costs: nanoseconds per step of the scenario loop, measured (never asserted in a test).

:func:`filter_costs` runs one fixed scenario (paper A's model, σ constant; a reading every step unless the scenario
says otherwise) with the loop's own three filters — the clairvoyant, the σ(0)-optimal Kalman–Bucy and the ISL filter
— alone, then with ``copies`` copies of each filter beside them, and reports

    ns/step(f) = (min over repeats of t(base + copies of f) − min over repeats of t(base)) / (copies · N)

and the base's own ns/step. Copies fill the loop's lanes of four (:mod:`isl_core.kernels.scenario`) as a table with
several filters does, so a lane filter's figure is its share of a full lane, not the cost of an idle lane's padding; the
IMM filter's bank runs outside the lanes and costs per mode, so it is measured with one copy (more would only multiply
the measurement's time; its share of a lane, then left out, is small beside its bank's cost). Timings depend on the
machine and on what else runs on it: they are figures to compare side by side in one call, not constants.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

from ..filters.base import FilterSpec
from ..model import Model
from ..validate import check_int, check_real
from .base import Scenario
from .run import ScenarioPlan, plan_scenario

__all__ = ["Costs", "filter_costs"]


@dataclass(frozen=True)
class Costs:
    """``ns_per_step`` per filter name (a copy's share), ``base`` the loop with its three filters alone, the grid's
    ``steps`` N, the ``copies`` and ``repeats`` of the measurement and its description ``how``."""

    ns_per_step: dict[str, float]
    base: float
    steps: int
    copies: int
    repeats: int
    how: str


def _best(plan: ScenarioPlan, repeats: int) -> float:
    plan.run(0)  # compiled and warm
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        plan.run(1)
        best = min(best, time.perf_counter() - start)
    return best


def filter_costs(
    model: Model,
    filters: Sequence[FilterSpec],
    *,
    scenario: Scenario | None = None,
    horizon: float = 200.0,
    copies: int = 8,
    repeats: int = 7,
) -> Costs:
    """ns per step of each of ``filters`` (module docstring) on ``scenario`` (default σ constant) over ``horizon``
    (1/r_min) of ``model``, the ISL filter of the base at ν = β.

    Parameters
    ----------
    model : Model
        The model.
    filters : sequence of FilterSpec
        The filters measured.
    scenario : Scenario, optional
        Default σ constant.
    horizon : float, default 200.0
        Length of the measured run, units of 1/r_min.
    copies, repeats : int
        Copies of a lane filter in the loop (of the IMM filter, one); runs whose minimum is kept.

    Returns
    -------
    Costs
        ``ns_per_step`` per filter name, the ``base`` loop's own, and how it was measured.

    Examples
    --------
    >>> from isl_core import filter_costs, isl_filter
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> costs = filter_costs(model, [isl_filter(model, model.beta)], horizon=20.0, copies=2, repeats=2)
    >>> list(costs.ns_per_step), costs.copies
    (['isl'], 2)
    """
    horizon = check_real("horizon", horizon, lo=1.0, hi=1e4)
    copies = check_int("copies", copies, lo=1, hi=64)
    repeats = check_int("repeats", repeats, lo=1, hi=100)
    scenario = Scenario() if scenario is None else scenario
    grid_of_all = list(filters)  # one grid for every measurement: the step of the fastest filter in play
    base_plan = _narrowed(model, scenario, horizon, [], grid=grid_of_all)
    h, n = base_plan.h, base_plan.N
    base = _best(base_plan, repeats)
    out = {}
    for spec in filters:
        k = 1 if spec.imm is not None else copies  # the bank runs outside the lanes (module docstring)
        plan = _narrowed(model, scenario, horizon, [spec] * k, grid=grid_of_all)
        out[spec.name] = max(0.0, (_best(plan, repeats) - base) / (k * n) * 1e9)
    return Costs(
        out,
        base / n * 1e9,
        n,
        copies,
        repeats,
        f"min of {repeats} runs of {n:,} steps (h = {h:.3g}, σ constant), {copies} copies of a filter (of the IMM "
        "filter, one) beside the loop's clairvoyant, Kalman–Bucy and ISL filters, minus those alone, per copy and step",
    )


def _narrowed(
    model: Model,
    scenario: Scenario,
    horizon: float,
    extra: Sequence[FilterSpec],
    grid: Sequence[FilterSpec] | None = None,
) -> ScenarioPlan:
    """A plan with ``extra`` on the grid set by ``grid`` (default ``extra``): the same h and N for every one."""
    return plan_scenario(model, model.beta, scenario, horizon=horizon, windows=1, extra=extra, grid_filters=grid)
