"""Scenarios beyond paper A's model, the filters run through them, and what is drawn from those runs.

* :mod:`~isl_core.scenario.base` — :class:`Scenario` (σ(t), the noise's law, the sensor interval) and the
  clairvoyant reference that knows it (:func:`clairvoyant`);
* :mod:`~isl_core.scenario.run` — one run of every filter against that reference, in time (:func:`simulate_scenario`);
* :mod:`~isl_core.scenario.learners` — the σ-learning filters at the start of a run;
* :mod:`~isl_core.scenario.average` — runs over seeds, their rolling ratios (:func:`average_scenario`);
* :mod:`~isl_core.scenario.periods` — the period statistic and its paired margins (:func:`period_ratios`);
* :mod:`~isl_core.scenario.presets` — the table's scenarios (:data:`PRESETS`) and those beyond every assumed σ range
  (:data:`BEYOND`);
* :mod:`~isl_core.scenario.variants` — the families, their knobs and grids (:class:`TuningGrids`);
* :mod:`~isl_core.scenario.minimax` — one tuning rule for every family's knob, the minimax (:class:`Tuning`);
* :mod:`~isl_core.scenario.tasks` — the runs a tuning is made of, every variant on common noise;
* :mod:`~isl_core.scenario.tuning` — the tuning as a job: a request in, cached (:func:`tune`);
* :mod:`~isl_core.scenario.heldout` — the tuned filters on seeds the tuning never saw (:func:`held_out`);
* :mod:`~isl_core.scenario.cells` — a table's cells at the worst coordinate, with the worst seed;
* :mod:`~isl_core.scenario.table` — the fair table (:func:`scenario_table`);
* :mod:`~isl_core.scenario.map` — who wins over a grid of scenarios (:func:`who_wins_map`);
* :mod:`~isl_core.scenario.cost` — each filter's cost per step in the scenario loop (:func:`filter_costs`).
"""

from __future__ import annotations

from .average import Rolling, ScenarioAverage, average_scenario
from .base import NOISE_LAWS, SIGMA_SHAPES, Clairvoyant, Scenario, clairvoyant, sigma_path
from .cost import Costs, filter_costs
from .heldout import HeldOut, held_out
from .map import MAPS, WhoWinsMap, who_wins_map
from .minimax import Tuning
from .periods import Period, PeriodRatios, paired_margin, period_ratios, scenario_periods
from .presets import BEYOND, PRESETS
from .run import ScenarioPlan, ScenarioRun, plan_scenario, scenario_grid, simulate_scenario
from .table import ScenarioTable, TableRow, scenario_table, table_from
from .tuning import TUNING_SAMPLING, tune
from .variants import FAMILIES, TuningGrids

__all__ = [
    "BEYOND",
    "FAMILIES",
    "MAPS",
    "NOISE_LAWS",
    "PRESETS",
    "SIGMA_SHAPES",
    "TUNING_SAMPLING",
    "Clairvoyant",
    "Costs",
    "HeldOut",
    "Period",
    "PeriodRatios",
    "Rolling",
    "Scenario",
    "ScenarioAverage",
    "ScenarioPlan",
    "ScenarioRun",
    "ScenarioTable",
    "TableRow",
    "Tuning",
    "TuningGrids",
    "WhoWinsMap",
    "average_scenario",
    "clairvoyant",
    "filter_costs",
    "held_out",
    "paired_margin",
    "period_ratios",
    "plan_scenario",
    "scenario_grid",
    "scenario_periods",
    "scenario_table",
    "sigma_path",
    "simulate_scenario",
    "table_from",
    "tune",
    "who_wins_map",
]
