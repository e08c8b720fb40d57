"""The table's scenarios: the presets over which every family's knob is tuned (:mod:`isl_core.scenario.tuning`) and the
fair table (:mod:`isl_core.scenario.table`) is drawn. Times in units of 1/r_min of paper A's model at σ(0).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from ..validate import check_real
from .base import Scenario

__all__ = ["BEYOND", "DEFAULT_RATE", "PRESETS", "RATES", "at_rate", "check_rate", "read_at"]

DEFAULT_RATE = 100.0  #: readings per 1/r_min at σ(0) of the table, the tuning and the page (:ref:`reading-rate`)
RATES = (10.0, 30.0, 100.0)  #: the rates the findings give the table at
RATE_MAX = 1e5  #: readings per 1/r_min: beyond, a run of the table's horizon exceeds the steps simulated

#: name: (label, σ(0), scenario)
PRESETS: Mapping[str, tuple[str, float, Scenario]] = {
    "sigma_drop": ("σ 200 → 2 at 10/r_min", 200.0, Scenario(sigma_knots=((10.0, 2.0),))),
    "sigma_rise": ("σ 2 → 200 at 10/r_min", 2.0, Scenario(sigma_knots=((10.0, 200.0),))),
    "student3": ("Student-t noise, 3 degrees of freedom", 20.0, Scenario(noise="student", dof=3.0)),
    "outliers": ("1 % outliers × 30", 20.0, Scenario(noise="outliers", outlier_rate=0.01, outlier_scale=30.0)),
    "sensor": ("sensor read every 0.1/r_min", 20.0, Scenario(sensor_interval=0.1)),
    "constant": ("constant σ, Gaussian", 20.0, Scenario()),
}

#: σ beyond every range a filter assumes (the adaptive and robust filters' [2, 200], the IMM's grid over [1.5, 500]):
#: never tuned over — the table runs the tuned filters through them on the report seeds, as a test of the
#: assumptions themselves
BEYOND: Mapping[str, tuple[str, float, Scenario]] = {
    "sigma_2000": ("constant σ = 2000", 2000.0, Scenario()),
    "sigma_drop_far": ("σ 200 → 0.5 at 10/r_min", 200.0, Scenario(sigma_knots=((10.0, 0.5),))),
}


def check_rate(rate: float | None) -> float | None:
    """``rate`` (readings per 1/r_min at σ(0)) checked: a number in (0, :data:`RATE_MAX`], or None (a reading every
    step of the Euler grid, whatever that step is)."""
    if rate is None:
        return None
    return check_real("rate (sensor readings per 1/r_min)", rate, lo=0.0, lo_open=True, hi=RATE_MAX)


def read_at(scenario: Scenario, rate: float | None) -> Scenario:
    """``scenario`` read at ``rate`` readings per 1/r_min at σ(0) (:ref:`reading-rate`): its sensor interval 1/``rate``,
    or its own when longer (a slower sensor keeps it); unchanged for ``rate`` None."""
    rate = check_rate(rate)
    if rate is None:
        return scenario
    return dataclasses.replace(scenario, sensor_interval=max(scenario.sensor_interval, 1.0 / rate))


def at_rate(
    presets: Mapping[str, tuple[str, float, Scenario]], rate: float | None
) -> dict[str, tuple[str, float, Scenario]]:
    """The presets read at ``rate`` (:func:`read_at`)."""
    rate = check_rate(rate)
    return {k: (lab, s0, read_at(sc, rate)) for k, (lab, s0, sc) in presets.items()}
