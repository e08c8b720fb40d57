"""The dashboard's Scenario group (app.scenario, app.views.scenario): inputs, the picture through the core, the map."""

from __future__ import annotations

import csv
import html
import io

import numpy as np
import pytest

from app import scenario_picture
from app.colors import contrast, text_on, tint
from app.scenario_picture import LOOP, PICTURE_MAX_STEPS, picture_filters
from app.state import AppState
from app.state.scenarios import PRESETS
from app.urlsync import query_string, read_query
from app.views.scenario import ScenarioView
from app.views.scenario_tables import SCENARIO_COLORS, map_html, periods_html
from isl_core import Scenario, average_scenario, plan_scenario, shipped_tuning, who_wins_map
from isl_core.scenario.table import PRESETS as TABLE_PRESETS


@pytest.fixture
def state():
    s = AppState()
    s.start()
    return s


@pytest.mark.parametrize(
    "name, bad, named",
    [
        ("sc_change", "jump", "σ change"),
        ("sc_noise", "cauchy", "noise law"),
        ("sc_dof", 2.0, "degrees of freedom"),
        ("sc_outlier_rate", 0.9, "outlier fraction"),
        ("sc_sensor", -1.0, "sensor interval"),
        ("sc_runs", 1000, "runs averaged"),
        ("sc_window", 0.0, "rolling window"),
        ("sc_map", "space", "map over"),
    ],
)
def test_a_bad_scenario_input_is_refused_by_name_and_keeps_its_value(state, name, bad, named):
    before = state.get(name)
    state.set(name, bad)
    assert state.get(name) == before
    assert state.message_kind == "danger" and named in state.message and "must be" in state.message


def test_the_link_carries_the_scenario_and_reports_bad_values(state):
    state.set_inputs({"sc_noise": "student", "sc_dof": 4.0, "sc_change": "none"})
    query = query_string(state)
    assert "sc_noise=student" in query and "sc_change=none" in query
    values, problems = read_query(query)
    assert values["sc_noise"] == "student" and values["sc_dof"] == 4.0 and values["sc_change"] == "none"
    _, problems = read_query("?sc_noise=student;drop&sc_runs=abc")
    assert set(problems) == {"sc_noise", "sc_runs"}
    assert "sc_noise=… in the link" in problems["sc_noise"]


def test_the_picture_is_the_cores_average_for_the_same_request(state):
    # α = 0, paper B's model: no tuning, the filters at their constructors' defaults
    state.set_inputs({"sc_runs": 4, "sc_horizon": 14.0, "sc_change_at": 6.0, "alpha": 0.0, "beta_from_w": False})
    state.scenarios.want()  # outside a server the job runs inline
    pic = state.scenarios.picture
    assert pic is not None and "Simulated in" in state.scenarios.note and "4 runs" in state.scenarios.note
    req = pic.request
    assert req.scenario == Scenario(sigma_knots=((6.0, 2.0),), sensor_interval=0.01)  # read at the table's rate
    direct = average_scenario(
        req.model,
        state.nu,
        req.scenario,
        seeds=range(state.seed, state.seed + 4),
        horizon=14.0,
        windows=140,
        extra=picture_filters(req, None)[0],
    )
    np.testing.assert_array_equal(pic.average.mse, direct.mse)
    roll = direct.rolling(1.0)
    np.testing.assert_array_equal(pic.rolling.ratio, roll.ratio)
    assert pic.average.run.names == (
        "clairvoyant",
        "kbf",
        "isl",
        "isl_model",
        "kbf_adaptive",
        "vb",
        "kbf_robust",
        "imm",
    )
    assert pic.tuned is None and set(pic.tuning.values()) >= {"untuned: the constructor's default"}
    assert pic.origin.startswith("untuned: α = 0 (paper B's model) has no tuning")
    # an input change recomputes it (the tab is open)
    state.scenarios.noise = "outliers"
    assert state.scenarios.picture.request.scenario.noise == "outliers"


def test_a_picture_too_long_for_the_dashboard_is_refused_with_the_setting_to_lower(state):
    state.set_inputs({"sc_runs": 256, "sc_horizon": 500.0})
    state.scenarios.want()
    assert state.scenarios.picture is None
    assert "sc_runs" in state.scenarios.note and f"{PICTURE_MAX_STEPS:,}" in state.scenarios.note
    state.set_inputs({"sc_horizon": 5.0, "sc_window": 8.0})
    assert "sc_window" in state.scenarios.note and "not be longer" in state.scenarios.note


def test_a_preset_sets_the_tables_column(state):
    label = "σ 2 → 200 at 10/rₘᵢₙ"  # the table's column, as the page writes it
    state.scenarios.apply_preset(label)
    assert (state.alpha, state.w, state.m, state.sigma) == (1.0, 3.0, 3, 2.0)
    assert (state.scenarios.change, state.scenarios.change_at, state.scenarios.sigma_after) == ("step", 10.0, 200.0)
    assert state.nu == pytest.approx(0.849, abs=5e-4)  # β·(A.31)'s ν/β at α = 1, as the table runs it
    assert set(PRESETS) >= {label, "Student-t noise, 3 degrees of freedom", "sensor read every 0.1/rₘᵢₙ"}
    state.scenarios.apply_preset("nonsense")
    assert "Unknown scenario preset" in state.message


def test_the_picture_reads_the_sensor_at_the_tables_rate_and_says_so(state):
    """Every filter of the picture takes one reading per 1/100 of 1/r_min (the table's rate), whatever the Euler
    step; a slower sensor input keeps its own interval."""
    state.set_inputs({"sc_runs": 2, "sc_horizon": 6.0, "sc_change": "none"})
    state.scenarios.want()
    run = state.scenarios.picture.average.run
    assert run.q * run.h * run.r_min == pytest.approx(0.01, rel=1e-12) and run.q > 1
    assert "every filter reads the sensor 100 times per 1/rₘᵢₙ at σ(0)" in state.scenarios.note
    state.set_inputs({"sc_sensor": 0.5})
    run = state.scenarios.picture.average.run
    assert run.q * run.h * run.r_min == pytest.approx(0.5, rel=1e-12)
    assert "reads the sensor 2 times per 1/rₘᵢₙ" in state.scenarios.note


def test_the_csv_holds_every_window_and_filter(state):
    state.set_inputs({"sc_runs": 3, "sc_horizon": 10.0})
    state.scenarios.want()
    text = state.scenarios.csv().getvalue()
    head = [line for line in text.splitlines() if line.startswith("#")]
    assert any("sigma(0)=20" in line for line in head) and any("Scenario(" in line for line in head)
    rows = list(csv.DictReader(io.StringIO("\n".join(line for line in text.splitlines() if not line.startswith("#")))))
    assert len(rows) == len(state.scenarios.picture.rolling.t)
    assert {"ratio_clairvoyant", "high_isl", "sigma_hat_vb", "coordinate_isl_model"} <= set(rows[0])


def test_the_view_draws_the_picture_and_the_period_table(state):
    state.set_inputs({"sc_runs": 3, "sc_horizon": 13.0})
    view = ScenarioView(state=state)
    data = view._ratio_src.data
    assert len(data["t"]) == len(state.scenarios.picture.rolling.t) and "isl_model_high" in data
    assert set(view._sigma_src.data) == {"t", "sigma", "kbf_adaptive", "vb", "kbf_robust", "imm"}
    assert view._change.visible and view._change.location == 10.0
    pic = state.scenarios.picture
    table = periods_html(pic, pic.costs)
    assert table.count("<tr>") == 1 + len(pic.average.run.names) and "class='best'" in table
    assert "first 1/rₘᵢₙ after the change" in table and "untuned" not in table
    pr = pic.periods  # each cell at its worst coordinate, with the worst run's own ratio
    assert f"X{pr.coordinate[2, 0] + 1} · worst run {pr.worst_seed[2, 0]:.3g}" in table
    np.testing.assert_array_equal(pr.ratio, pr.coordinates.max(axis=2))
    assert set(pic.costs) == {"loop"} | set(pic.average.run.names) - set(LOOP)
    assert all(v >= 0 for v in pic.costs.values())
    assert table.count("the 3 together") == 1 and table.count("rowspan='3'") == 1  # the loop's three share one cost
    state.scenarios.runs = 1  # one run: no interval, no period statistic, said so
    assert "No period statistic from one run" in periods_html(state.scenarios.picture)


def test_the_default_pages_scenarios_tab_shows_no_untuned_row(state, monkeypatch, tmp_path):
    """Without a tuning computed for the page's model, the shipped one at its grid point (the default page's model
    is one) gives every filter its knob, on its grid and held-out seeds; a model between grid points takes the
    nearest, and the table's caption, the rows and the tuning part say so."""
    monkeypatch.setenv("ISL_CACHE_DIR", str(tmp_path))  # no tuning computed here: the shipped one
    state.set_inputs({"sc_runs": 2, "sc_horizon": 12.0})  # the default model, a short scenario
    view = ScenarioView(state=state)
    pic = state.scenarios.picture
    ship = shipped_tuning(state.alpha, state.m, state.w)
    assert pic.shipped == ship and ship.exact and pic.tuned is None and state.scenarios.tuning is None
    assert pic.average.seeds[0] == state.seed + len(ship.seeds)  # held out from the tuning's seeds
    table = view._periods.object
    assert "untuned" not in table and "Knobs: shipped tuning, tuned at α = 0.5, m = 3 (grid at m = 3: α ∈" in table
    vb = ship.knobs[ship.minimax("vb")]
    assert pic.tuning["vb"] == f"tuned: W = {vb['memory']:g} readings"
    assert all(pic.tuning[n].startswith("tuned") for n in pic.average.run.names[3:])
    assert "tuned at α = 0.5, m = 3" in view._tuning._note.object and "**Tune** computes" in view._tuning._note.object
    state.set_inputs({"alpha": 0.7})  # between grid points: the nearest in log α, labelled
    pic = state.scenarios.picture
    assert pic.shipped.alpha == 0.5 and "your α = 0.7: nearest grid point" in view._periods.object
    assert pic.tuning["vb"].startswith("tuned at α = 0.5, m = 3 (nearest grid point): W = ")


def test_a_tuned_model_runs_every_filter_at_its_tuned_knob_on_the_tunings_grid(state, monkeypatch, tmp_path):
    """With a tuning for the page's α, m and w, the filters that do not know σ(t) take its minimax knobs, run on its
    grid (a memory of W readings spans what it spanned there), and say so; the tuning curves mark the minimax point
    and each preset's own best (the oracle reference)."""
    from isl_core import Execution, Sampling
    from isl_core.scenario.tuning import TuningGrids, tune

    grids = TuningGrids(isl_ell=(-4.0, -2.0), memory=(10.0, 100.0), robust_c=(2.0,), imm_switch=(0.01,), imm_modes=(6,))
    small = tune(
        1.0,
        sampling=Sampling.first(2, horizon=12.0, burn=2.0),
        grids=grids,
        presets={k: v for k, v in TABLE_PRESETS.items() if k in ("sigma_drop", "constant")},
        execution=Execution(cache=False),
    )
    monkeypatch.setattr(scenario_picture, "tuning_for", lambda req: small)
    state.set_inputs({"alpha": 1.0, "sc_runs": 2, "sc_horizon": 12.0})
    state.scenarios.want()
    pic = state.scenarios.picture
    assert pic.tuned is small and state.scenarios.tuning is small
    first = state.seed + 2  # the seed input counts from the first seed after the tuning's 0–1: held out
    assert pic.average.seeds == (first, first + 1) and f"seeds {first}–{first + 1}, held out" in pic.origin
    assert f"(seeds {first}–{first + 1})" in state.scenarios.note
    assert pic.average.run.names[3:] == ("isl_tuned", "isl_model", "kbf_adaptive", "vb", "kbf_robust", "imm")
    vb = small.knobs[small.minimax("vb")]
    assert pic.tuning["vb"] == f"tuned: W = {vb['memory']:g} readings"
    req = pic.request  # on the tuning's grid: h set by every variant of the tuning, not by the picture's filters
    on_grid = plan_scenario(
        req.model,
        req.nu,
        req.scenario,
        horizon=12.0,
        extra=picture_filters(req, small)[0],
        grid_filters=small.grid_filters(req.model),
    )
    assert pic.average.run.h == on_grid.h
    from app.views.tuning import TuningView, curves

    view = TuningView(state=state)
    view._family.value = "vb"
    x, per_preset, largest, best = curves(small, "vb")
    assert list(x) == [10.0, 100.0] and largest[best] == largest.min() and view._mark.location == x[best]
    dots = view._oracle.data  # each preset's own best (oracle) on its curve, the core's oracle knob in the note
    assert list(dots["y"]) == list(per_preset.min(axis=1))
    assert [small.knobs[small.oracle("vb", p)]["memory"] for p in range(2)] == list(dots["x"])
    assert "Oracle-tuned" in view._note.object
    # out of sample: said not computed until the held-out runs are cached, then this family's verdict on them
    assert "Out of sample: not computed" in view._note.object
    from isl_core.scenario.heldout import held_out
    from isl_core.scenario.table import table_from

    monkeypatch.setenv("ISL_CACHE_DIR", str(tmp_path))
    table = table_from(small, held=held_out(small, beyond={}))  # cached in tmp_path; the view reads it
    monkeypatch.setattr("app.views.tuning.held_out", lambda t, compute: held_out(t, compute=compute, beyond={}))
    view = TuningView(state=state)
    view._family.value = "vb"
    r = next(i for i, row in enumerate(table.rows) if row.name == "vb")
    assert f"Out of sample (seeds 2–9, never used to tune): its worst cell reads {table.held_figure[r]:.3g}" in (
        view._note.object
    )


def test_the_tune_button_hands_the_long_job_a_tuning_that_reports_its_progress(state, monkeypatch):
    """The job the Tune button starts takes ``progress=`` (as every long job does) and gives it to the core's tuning
    for the page's α, m and w through its execution."""
    started, asked = [], []
    monkeypatch.setattr(state.scenarios._tune_task, "start", lambda fn, apply, note: started.append(fn))
    monkeypatch.setattr("app.state.scenarios.tune", lambda alpha, **kw: asked.append((alpha, kw)))
    state.set_inputs({"alpha": 0.5, "m": 2})
    state.scenarios.compute_tuning()
    (fn,) = started
    fn(progress=print)
    ((alpha, kw),) = asked
    assert alpha == 0.5 and kw["m"] == 2 and kw["execution"].progress is print and kw["execution"].cache


def test_the_map_runs_as_a_long_job_and_marks_ties(state):
    state.set_inputs({"sc_map": "sensor", "sc_map_seeds": 2})
    state.scenarios.compute_map()
    res = state.scenarios.map_result
    assert res is not None and res.kind == "sensor" and "Simulated in" in state.scenarios.map_note
    assert f"2 runs per cell (seeds {res.seeds[0]}–{res.seeds[1]})" in state.scenarios.map_note and len(res.seeds) == 2
    page = map_html(res)
    assert page.count("class='cell") == len(res.x)
    assert page.count("≈ ") == int(res.tie.sum())
    assert res.model.beta == pytest.approx(state.beta_effective)
    # β as an input: the map is for that β (paper A's model with w = β/√(2α)), not for the w slider's
    state.set_inputs({"beta_from_w": False, "beta": 2.5})
    state.scenarios.compute_map()
    assert state.scenarios.map_result.model.beta == pytest.approx(2.5) and "β = 2.5" in state.scenarios.map_note
    state.alpha = 0.0
    state.scenarios.compute_map()
    assert "needs α > 0" in state.scenarios.map_note


def test_the_map_cells_name_the_winner_in_text_that_reads_at_4_5_to_1():
    """A cell is its winner's colour (a tie: a light shade of it), its text black or white, whichever reads better:
    at least 4.5 : 1 (WCAG 2.1 AA) — white on cyan or yellow read at 2.1 : 1."""
    res = who_wins_map("tails", 1.0, values=[3.0], n_seeds=3)
    winner = res.winner[0, 0]
    color = SCENARIO_COLORS[res.filters[winner]]
    back = tint(color, 0.3) if res.tie[0, 0] else color
    cell = map_html(res)
    assert f"title='{html.escape(res.labels[winner])}'" in cell
    assert f"background:{back};color:{text_on(back)}" in cell
    for color in SCENARIO_COLORS.values():
        for shade in (color, tint(color, 0.3)):
            assert contrast(text_on(shade), shade) >= 4.5, shade


def test_closing_the_session_drops_the_picture(state):
    state.set_inputs({"sc_runs": 2, "sc_horizon": 8.0})
    state.scenarios.want()
    assert state.scenarios.picture is not None
    state.close()
    assert state.scenarios.picture is None and state.scenarios.map_result is None


def test_the_first_picture_is_drawn_with_one_recompute_of_the_documents_models(state, monkeypatch):
    """The first picture in a page adds every filter's glyphs and legend items: each model-valued property set would
    walk every model of the page again; the view asks Bokeh for one walk at the end. A later picture relabels: none."""
    from bokeh.document import Document

    state.set_inputs({"sc_runs": 256, "sc_horizon": 500.0})  # refused: nothing drawn yet
    view = ScenarioView(state=state)
    assert state.scenarios.picture is None and not view._legend_items
    doc = Document()
    doc.add_root(view._ratio_fig)
    doc.add_root(view._sigma_fig)
    walks: list[int] = []
    recompute = doc.models.recompute
    monkeypatch.setattr(doc.models, "recompute", lambda: walks.append(1) or recompute())
    for runs, once in ((2, 1), (3, 0)):  # the first picture drawn in the document, then the next one
        walks.clear()
        state.set_inputs({"sc_runs": runs, "sc_horizon": 13.0})
        assert state.scenarios.picture.request.runs == runs
        assert len(walks) == once, walks
    names = state.scenarios.picture.average.run.names
    assert len(view._ratio_fig.legend[0].items) == len(names) and set(view._legend_items) == set(names)
    item = view._ratio_fig.legend[0].items[0]
    assert doc.get_model_by_id(item.id) is item  # the new models are the document's
