"""The Euler grid of a scenario run (:ref:`step-size`, :ref:`reading-rate`): the step h every filter of the run can
take, and with a sensor interval a whole number q of steps per reading, so that the readings are the sensor's
whatever the step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..filters.base import FilterSpec
from ..grid import MAX_STEPS, run_plan
from ..model import Model
from ..riccati import kalman_bucy
from ..validate import check_int
from .base import Scenario

__all__ = ["MAX_REFINE", "MAX_SCENARIO_STEPS", "scenario_grid"]

MAX_SCENARIO_STEPS = 20_000_000  #: steps of one run (memory is per window; its time: :ref:`performance-scenario`)
MAX_REFINE = 6  #: halvings of a sensor grid's step (2^6 = 64 steps per base step: :func:`scenario_grid`)


def scenario_grid(
    model: Model, nu: float, scenario: Scenario, extra: Sequence[FilterSpec], horizon: float, refine: int = 0
) -> tuple[float, int, float]:
    """(h, N, r_min) of a run of ``scenario``: h the smallest step over σ(0) and the extremes of σ(t) on [0, T]
    (:mod:`!isl_core.scenario.run`), N the steps over ``horizon``/r_min; a ``ValueError`` when N is over the limit.
    With a sensor interval Δ > 0, h is Δ/q₀ exactly, q₀ the fewest steps per reading that are no longer than that
    step, and ``refine`` halves it that many times (q = q₀·2^refine steps per reading; the noise's path is the same,
    :mod:`!isl_core.kernels.draws`): the readings stay the sensor's, only the simulation's step changes.

    Examples
    --------
    >>> import math
    >>> from isl_core import Scenario, run_plan, scenario_grid
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> h, n, r_min = scenario_grid(model, model.beta, Scenario(), (), 10.0)
    >>> plan = run_plan(model, model.beta, horizon=10.0)  # σ constant: the grid of simulate
    >>> math.isclose(h, plan.h), n == plan.N
    (True, True)
    """
    r_min = kalman_bucy(model).r_min
    T = horizon / r_min  # exactly: not lengthened for a slowly settling filter as simulate's default run is
    plan = run_plan(model, nu, T=T, extra=extra, cap=MAX_STEPS)
    # σ(t) is monotone between knots: its extremes on [0, T] are at 0, the knots and T
    sig = scenario.sigma_at(model.sigma, np.array([0.0, *(t for t, _ in scenario.sigma_knots if t < horizon), horizon]))
    h = plan.h
    for s in {float(sig.min()), float(sig.max())} - {model.sigma}:
        other = Model(model.alpha, model.beta, s, model.m)
        h = min(h, run_plan(other, nu, T=T, extra=extra, cap=MAX_STEPS).h)
    refine = check_int("refine (halvings of the step)", refine, lo=0, hi=MAX_REFINE)
    if scenario.sensor_interval > 0.0:
        span = scenario.sensor_interval / r_min  # one reading interval, in time
        q0 = max(1, math.ceil(span / h * (1.0 - 1e-12)))
        h0 = span / q0
        n = math.ceil(T / h0 * (1.0 - 1e-12)) << refine
        h = h0 / (1 << refine)
    elif refine:
        raise ValueError(
            f"refine = {refine} needs a sensor interval (a reading rate): with a reading every step, halving the step "
            "would double the readings"
        )
    else:
        n = math.ceil(plan.T / h)
        h = T / n
    if n > MAX_SCENARIO_STEPS:
        raise ValueError(
            f"horizon = {horizon:g} needs {n:,} steps of h = {h:.3g} at these σ values; at most "
            f"{MAX_SCENARIO_STEPS:,} are simulated: choose a shorter horizon, σ values closer together or a lower "
            "reading rate"
        )
    return h, n, r_min
