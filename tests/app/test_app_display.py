"""What the page says and keeps, headless: refusals beside their input, the view and the tab in the link, α = 0
unticked back to the α before, a scenario preset that says what it set, a theory that is refused where it does not
hold, numbers written plainly, widgets that turn an impossible browser value into a refusal, and a tab's part built
once the tab switch is done."""

from __future__ import annotations

import math

import pytest

from app.state import AppState
from app.state.scenarios import PRESETS as SCENARIO_PRESETS
from app.text import num, per_r_min
from app.urlsync import query_string, read_query
from app.views.controls import ControlsView, IntSlider, Slider, WholeInput, log_slider
from app.views.numbers import THEORY_OFF, numbers_html, theory_cell


@pytest.fixture
def state():
    s = AppState()
    s.start()
    return s


def test_a_refusal_is_kept_beside_its_input_until_it_gets_a_good_value(state):
    state.set("seed", -5)  # as the box sends it
    assert set(state.refusals) == {"seed"} and state.message_inline
    assert "seed must be a whole number from 0 to 2147483647; -5 is below that range" in state.refusals["seed"]
    state.sigma = 30.0  # another input's good value leaves the refusal where it is
    assert "seed" in state.refusals
    state.seed = 4  # a good value, from anywhere
    assert state.refusals == {} and state.message == ""


def test_a_links_refusals_are_reported_at_the_top_and_beside_each_input(state):
    values, problems = read_query("?seed=abc&sigma=5000&nu=2")
    state.set_inputs(values, problems, link=True)
    assert set(state.refusals) == {"seed", "sigma"} and not state.message_inline
    assert "Refused 2 values" in state.message and state.nu == 2.0


def test_the_view_the_tab_and_presenter_mode_are_in_the_link_and_start_no_run(state):
    run = state.run
    state.param.update(view="errors", tab="scenarios", present=True)
    assert state.run is run  # how the run is shown is not a new run
    query = query_string(state)
    assert "view=errors" in query and "tab=scenarios" in query and "present=true" in query
    values, problems = read_query("?view=errors&tab=sweep&present=1")
    assert values == {"view": "errors", "tab": "sweep", "present": True} and problems == {}
    state.set_inputs(*read_query("?tab=settings"), link=True)
    assert "open tab (tab=… in the link) must be one of trajectories, sweep" in state.refusals["tab"]
    assert state.tab == "scenarios"


def test_unticking_alpha_zero_goes_back_to_the_alpha_before(state):
    controls = ControlsView(state=state)
    state.alpha = 2.5
    controls._alpha_zero.value = True
    assert state.alpha == 0.0
    controls._alpha_zero.value = False
    assert state.alpha == 2.5  # it went to the slider's end, 0.01


def test_a_scenario_preset_says_which_model_inputs_it_set(state):
    label = next(k for k in SCENARIO_PRESETS if "200 → 2" in k)
    state.scenarios.apply_preset(label)
    preset = SCENARIO_PRESETS[label]
    assert state.sigma == preset["sigma"] == 200.0 and state.nu == preset["nu"]
    for part in ("α = 1", "σ(0) = 200", f"ν = {num(preset['nu'], 3)}", "sidebar"):
        assert part in state.scenarios.preset_note and part in state.message, part


def test_the_theory_is_refused_where_the_filter_has_lost_lock(state):
    """At ν = 0.001 the ISL filter's measured ratio is tens of times the linearization's: the table says the theory
    does not hold instead of showing it beside the measurement."""
    state.nu = 0.001
    run, pred = state.run, state.prediction
    off = [i for i in range(run.model.m) if run.ratio_check[i] > THEORY_OFF * pred[i]]
    assert off, (run.ratio_check, pred)  # the run itself shows the loss of lock
    text = numbers_html(run, pred, 0.0)
    assert text.count("not valid") == len(off) and f"{pred[off[0]]:.4g}" not in text.split("not valid")[0][-200:]
    assert text.count("has lost lock") == 1  # why, said once below the table: the cells stay narrow
    assert theory_cell(1.2, 1.1).endswith(">1.1</td>") and "unstable" in theory_cell(1.2, math.inf)


@pytest.mark.parametrize(
    ("x", "text"),
    [
        (1000.0, "1000"),
        (0.849, "0.849"),
        (12345.6, "12346"),
        (2.5e8, "2.5 × 10^8"),
        (-3.2, "−3.2"),
        (3.333e-4, "0.0003333"),
        (1e-7, "1 × 10^−7"),
    ],
)
def test_numbers_are_written_plainly(x, text):
    assert num(x) == text
    assert per_r_min(1000.0) == "1000/rₘᵢₙ"  # not 1e+03/r_min


def test_a_value_a_widget_cannot_take_is_refused_by_the_state_without_an_error(state):
    """A scripted browser sent nan to the m slider, 10³⁰⁸ to a log slider, 2.5 to the seed box: Panel raised while
    converting it, and the page showed an error notification instead of the refusal that names the input."""
    from app.views.controls import _plain

    sigma = log_slider(state, "sigma")
    m = _plain(state, "m", IntSlider(label="m", start=1, end=6, value=3))
    seed = _plain(state, "seed", WholeInput(label="seed", value=1))
    run = state.run
    cases = [
        (sigma, "sigma", math.nan),
        (sigma, "sigma", math.inf),
        (sigma, "sigma", 1e308),
        (m, "m", math.nan),
        (m, "m", 2.5),
        (m, "m", -7.0),
        (seed, "seed", 2.5),
        (seed, "seed", math.inf),
        (seed, "seed", math.nan),
    ]
    for widget, name, bad in cases:
        before = getattr(state, name)
        widget._process_events({"value": bad})  # what Panel calls with a browser's change (it raised before)
        assert getattr(state, name) == before and state.run is run
        assert "must be" in state.refusals.get(name, ""), (name, bad, state.refusals)
    assert isinstance(sigma, Slider)


def test_the_pages_location_keeps_as_text_a_value_panels_parser_cannot_convert():
    """Panel's Location parses its query whenever its search changes, and turns a 5000-digit seed into an int, over
    Python's limit: the page's script failed before the dashboard's own parser could refuse the value in words. The
    page's Location (``app.serving.session.page_location``) keeps that value as text."""
    from types import SimpleNamespace

    from bokeh.document import Document
    from panel.io.location import Location

    from app.serving.session import PageLocation, page_location

    query = "?sigma=20&seed=" + "7" * 5000
    with pytest.raises(ValueError, match="4300"):  # Panel's parse (if it stops raising, PageLocation can go)
        Location().search = query
    location = PageLocation()
    location.search = query
    assert location.query_params == {"sigma": 20, "seed": "7" * 5000}
    doc = Document()
    context = SimpleNamespace(request=None)
    doc._session_context = lambda: context  # (a served session's context, as bokeh holds it)
    assert isinstance(page_location(doc), PageLocation) and page_location(doc) is page_location(doc)
    assert not isinstance(page_location(Document()), PageLocation)  # outside a served session: Panel's own


def test_distinct_filters_are_drawn_apart_by_colour_and_not_by_colour_alone():
    """The constant-σ Kalman–Bucy line and the IMM's were both green (ΔE 15.8) and every scenario line was solid; the
    worst case drew every filter as the same circle."""
    from itertools import combinations

    from app.colors import difference
    from app.views.scenario_tables import SCENARIO_COLORS
    from app.views.style import FILTER_COLORS, FILTER_MARKERS, SCENARIO_DASHES

    for colors in (SCENARIO_COLORS, FILTER_COLORS):
        close = [(a, b) for (a, x), (b, y) in combinations(colors.items(), 2) if difference(x, y) < 20]
        assert close == []
    assert difference("#1b7837", "#1a9641") < 20  # (the two greens, for the scale)
    assert set(SCENARIO_DASHES) == set(SCENARIO_COLORS) and len({str(d) for d in SCENARIO_DASHES.values()}) == len(
        SCENARIO_DASHES
    )
    assert set(FILTER_MARKERS) == set(FILTER_COLORS) and len(set(FILTER_MARKERS.values())) == len(FILTER_MARKERS)


def test_a_tab_opened_for_the_first_time_is_built_from_the_sessions_loop_not_from_the_watcher(monkeypatch):
    # Panel applies a tab switch to the page on the session's loop; the part's build is handed to that loop too (the
    # state's ``later``), so it starts once the switch is applied instead of competing with it for the interpreter
    import panel as pn

    from app.jobs import Jobs, Outcome
    from app.page import on_first_open

    scheduled, submitted = [], []
    jobs = Jobs(schedule=scheduled.append)
    monkeypatch.setattr(jobs, "submit", lambda kind, fn, done, pool="run": submitted.append((kind, pool, fn, done)))
    state = AppState(jobs=jobs)
    holder = on_first_open(state, "worstcase", lambda: pn.pane.Markdown("the part"))
    state.tab = "worstcase"
    assert submitted == [] and scheduled, "the build must wait for the loop"
    while scheduled:
        scheduled.pop(0)()
    assert [(kind, pool) for kind, pool, _, _ in submitted] == [("tab:worstcase", "view")]
    state.tab, state.tab = "trajectories", "worstcase"
    while scheduled:
        scheduled.pop(0)()
    assert len(submitted) == 1  # built once
    part = pn.pane.Markdown("the part")
    submitted[0][3](Outcome(value=part), False)  # the build's outcome, shown
    assert holder.objects == [part]
