"""Verdicts out of sample (isl_core.scenario.heldout, the table read on report seeds): held-out runs, flags, the
worst seed and the worst coordinate; and σ̂ held inside the range a learner states."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from isl_core import Execution, Model, Sampling, Scenario, simulate_scenario
from isl_core.filters.adaptive import adaptive_kbf
from isl_core.filters.robust import robust_kbf
from isl_core.filters.variational import variational_kbf
from isl_core.scenario.heldout import held_out, report_columns
from isl_core.scenario.presets import BEYOND
from isl_core.scenario.table import beyond_rows, beyond_stats, table_from
from isl_core.scenario.tuning import TuningGrids, tune

PRESETS = {
    "drop": ("σ 20 → 2 at 2/r_min", 20.0, Scenario(sigma_knots=((2.0, 2.0),))),
    "constant": ("constant σ", 20.0, Scenario()),
}
GRIDS = TuningGrids(isl_ell=(-4.0, -2.0), memory=(10.0, 100.0), robust_c=(2.0,), imm_switch=(1e-2,), imm_modes=(5,))
# a reading every Euler step: the held-out logic does not depend on the rate, and this keeps its runs the smallest
NO_CACHE = Execution(cache=False)
KW = {"presets": PRESETS, "grids": GRIDS, "execution": NO_CACHE, "rate": None}


def _first(n: int) -> Sampling:
    return Sampling.first(n, horizon=5.0, burn=2.0)


@pytest.fixture(scope="module")
def tuning():
    return tune(1.0, sampling=_first(2), **KW)


@pytest.fixture(scope="module")
def report(tuning):
    return held_out(tuning, execution=NO_CACHE)


def test_the_report_seeds_follow_the_tunings_and_their_runs_are_the_tunings_own(tuning, report):
    """Four times as many seeds, disjoint from the tuning's; and each held-out run is, bit for bit, the run a tuning
    over those seeds makes of the same filter (the same grid, the same noise)."""
    assert tuning.seeds == (0, 1) and report.seeds == tuple(range(2, 10))
    assert report.columns == report_columns(tuning) and report.y.shape == (8, 4, len(report.columns), 3)
    wider = tune(1.0, sampling=_first(10), **KW)
    np.testing.assert_array_equal(report.y, wider.y[2:][:, :, list(report.columns)])


def test_the_table_runs_its_filters_beyond_every_assumed_range_and_says_what_each_assumes(tuning, report):
    assert list(report.beyond) == list(BEYOND) and report.beyond_y.shape[:2] == (8, len(report.beyond_cells))
    table = table_from(tuning, held=report)
    rows, st = beyond_rows(table), beyond_stats(table)
    assert [table.rows[r].role for r in rows].count("oracle") == 0 and st.ratio.shape == (len(rows), 2)
    assumed = {table.rows[r].name: table.rows[r].assumes for r in rows}
    assert "[2, 200]" in assumed["kbf_adaptive"] and "[1.5, 500]" in assumed["imm"]
    assert assumed["vb"].startswith("no range") and assumed["isl"].startswith("none")
    assert st.diverged.sum() == 0 and np.all(np.isfinite(st.coordinates))


def test_the_table_reads_the_report_seeds_and_flags_a_row_that_leaves_its_tuning_interval(tuning, report):
    table = table_from(tuning, held=report)
    tuned = [r for r, row in enumerate(table.rows) if row.role == "tuned"]
    assert all(table.seeds[r] == report.seeds for r in tuned)
    assert all(table.seeds[r] == tuning.seeds for r, row in enumerate(table.rows) if row.role == "oracle")
    # the tuning's own seeds read as "held out": every row's figure is its tuning-seed figure, none is flagged
    same = replace(report, seeds=tuning.seeds, y=tuning.y[:, :, list(report.columns)])
    honest = table_from(tuning, held=same)
    np.testing.assert_allclose(honest.held_figure[tuned], honest.tuned_figure[tuned], rtol=1e-12)
    assert not honest.flagged.any()
    # one tuned filter twice as bad on the report seeds leaves its interval: that row, and only it, is flagged
    worse = same.y.copy()
    vb = report.columns.index(tuning.minimax("vb"))
    worse[:, :, vb] *= 4.0
    flagged = table_from(tuning, held=replace(same, y=worse)).flagged
    assert [table.rows[r].name for r in np.flatnonzero(flagged)] == ["vb"]


def test_a_cell_gives_every_coordinate_the_worst_one_the_worst_seed_and_a_divergence(tuning, report):
    y = report.y.copy()
    imm = report.columns.index(tuning.minimax("imm"))
    y[5, 3, imm, 1] = np.inf  # seed 7 diverged in the constant preset's cell, on X₂
    y[2, 0, imm, 0] = 9.0  # seed 4 reads 3× on X₁ just after the drop
    table = table_from(tuning, held=replace(report, y=y))
    row, st = next(r for r, row in enumerate(table.rows) if row.name == "imm"), table.stats
    np.testing.assert_allclose(st.coordinates[row], np.sqrt(y[:, :, imm].mean(axis=0)), rtol=1e-12)
    finite = np.isfinite(st.ratio[row])
    np.testing.assert_array_equal(st.ratio[row][finite], st.coordinates[row].max(axis=1)[finite])
    assert st.ratio[row, 3] == np.inf and st.coordinate[row, 3] == 1  # never averaged away
    assert st.diverged[row].tolist() == [0, 0, 0, 1] and st.worst_seed_id[row, 3] == 7
    assert st.worst_seed[row, 0] >= 3.0 and st.above2[row, 0] >= 1 and st.worst_seed_id[row, 0] == 4
    assert table.held_figure[row] == np.inf and table.flagged[row]


def test_a_learner_with_a_range_keeps_its_estimate_inside_it_and_variational_bayes_states_none():
    """σ = 2000, ten times the top of the range [2, 200] the adaptive and robust filters state: their σ̂ stays at
    200, while the variational filter, which states no range, follows σ."""
    model = Model.from_w(1.0, 3.0, 2000.0, 3)
    extra = [
        adaptive_kbf(model, memory=50.0, sigma_init=20.0),
        robust_kbf(model, memory=50.0, sigma_init=20.0),
        variational_kbf(model, memory=50.0, sigma_init=20.0),
    ]
    run = simulate_scenario(model, model.beta, Scenario(), horizon=3.0, windows=6, extra=extra)
    adaptive, robust, vb = (run.sigma_hat[:, run.learning.index(n)] for n in ("kbf_adaptive", "kbf_robust", "vb"))
    assert np.all(adaptive <= 200.0 * (1 + 1e-12)) and np.all(robust <= 200.0 * (1 + 1e-12))
    assert adaptive[-1] > 190.0 and vb[-1] > 1000.0  # at the top of its range, mostly


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [({"n_seeds": 1}, r"^n_seeds \(report seeds\)"), ({"execution": Execution(executor=object())}, "executor")],
)
def test_bad_held_out_settings_are_named_before_any_run(tuning, kwargs, named):
    with pytest.raises(ValueError, match=named):
        held_out(tuning, **kwargs)
