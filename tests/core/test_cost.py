"""Each filter's cost (isl_core.scenario.cost): measured per step on one grid — what is reported, never how fast it
is."""

from __future__ import annotations

import dataclasses
import math

import pytest

from isl_core import Model, filter_costs, imm_kbf, isl_filter
from isl_core.scenario.run import plan_scenario

MODEL = Model.from_w(1.0, 3.0, 20.0, 3)


def test_every_filter_gets_a_figure_per_step_on_the_grid_of_them_all():
    specs = [dataclasses.replace(isl_filter(MODEL, 16.0 * MODEL.beta), name="fast_isl"), imm_kbf(MODEL, modes=3)]
    costs = filter_costs(MODEL, specs, horizon=2.0, copies=1, repeats=1)
    assert set(costs.ns_per_step) == {"fast_isl", "imm"}
    assert all(math.isfinite(v) and v >= 0.0 for v in costs.ns_per_step.values()) and costs.base > 0.0
    # the grid is that of every filter measured: the fast ISL filter's rate sets h for the IMM's runs too
    assert costs.steps == plan_scenario(MODEL, MODEL.beta, horizon=2.0, windows=1, extra=specs).N
    assert costs.steps > plan_scenario(MODEL, MODEL.beta, horizon=2.0, windows=1).N
    assert "min of 1 runs" in costs.how


def test_bad_settings_are_named():
    with pytest.raises(ValueError, match="copies"):
        filter_costs(MODEL, [], copies=0)


def test_lane_filters_are_measured_in_copies_and_the_imm_bank_alone(monkeypatch):
    """Copies fill the loop's lanes; the IMM's bank runs outside them, so its copies would only multiply the time."""
    from isl_core.scenario import cost

    measured, narrowed = {}, cost._narrowed

    def counting(model, scenario, horizon, extra, grid=None):
        if extra:
            measured[extra[0].name] = len(extra)
        return narrowed(model, scenario, horizon, extra, grid)

    monkeypatch.setattr(cost, "_narrowed", counting)
    specs = [isl_filter(MODEL, MODEL.beta), imm_kbf(MODEL, modes=3)]
    costs = filter_costs(MODEL, specs, horizon=2.0, copies=3, repeats=1)
    assert measured == {specs[0].name: 3, "imm": 1} and costs.copies == 3
    assert "of the IMM filter, one" in costs.how
