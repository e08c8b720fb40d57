"""The trajectories view (app.views.trajectories): what a run changes, what it leaves alone, the legend.

Headless: the bokeh models the view builds, without a server or a browser.
"""

import numpy as np
import pytest
from bokeh.models import Band, ColumnDataSource, GlyphRenderer

from app.state import AppState
from app.views.trajectories import EDGE, TrajectoriesView


@pytest.fixture
def view():
    state = AppState()
    state.start()
    return TrajectoriesView(state=state)


def test_plots_show_the_run_and_the_tube_is_three_s_around_the_kalman_bucy_estimate(view):
    run, traces = view.state.run, view.state.traces
    for i in range(run.model.m):
        for name, src in view._sources[i].items():
            np.testing.assert_array_equal(src.data["y"], traces.series[i][name][1])
        band = next(r for r in view._figures[i].center if isinstance(r, Band))
        assert band.source is view._sources[i]["kbf"]
        assert band.upper.transform.args["d"].value == pytest.approx(3 * run.s[i])
        assert band.lower.transform.args["d"].value == pytest.approx(-3 * run.s[i])
    assert [p.visible for p in view._column.objects] == [False, False, True]  # no indicator, no reason: the plots
    assert [p.object for p in view._plots.objects[2:]] == view._figures[: run.model.m]  # (after the mode, the legend)
    assert [f.xaxis[0].visible for f in view._figures[:3]] == [False, False, True]  # one time axis, at the bottom


def test_the_legend_reaches_nothing_a_run_changes(view):
    """A legend redraws when anything it references changes: it must not reach the plots' data or lines."""
    reachable = view._legend.references()
    plotted = {m for f in view._figures for m in f.references() if isinstance(m, (ColumnDataSource, GlyphRenderer))}
    assert reachable.isdisjoint(plotted)
    view.state.sigma = 200.0  # a run changes the plots, not the legend's figure
    assert all(len(s.data["t"]) == 2 for s in view._key_figure.select(type=ColumnDataSource))


def test_a_click_on_a_legend_entry_hides_that_trace_in_every_plot(view):
    key = view._keys["isl"].renderers[0]
    isl_lines = view._followers["isl"]
    assert len(isl_lines) == len(view._figures) and all(r.visible for r in isl_lines)
    key.visible = False  # what the browser sends when the entry is clicked (click_policy "hide")
    assert not any(r.visible for r in isl_lines) and all(r.visible for r in view._followers["kbf"])
    tube = view._followers["tube"]
    view._keys["tube"].renderers[0].visible = False
    assert all(isinstance(b, Band) and not b.visible for b in tube)
    key.visible = True
    assert all(r.visible for r in isl_lines)


def test_the_error_view_draws_each_filters_error_in_a_three_s_band_around_zero():
    """m = 6 at a long horizon: X₁ spans ±10⁵ and more, the tube is invisible beside it; the error view draws
    X̂_i − X_i, X̌_i − X_i (and each extra filter's) with the band ±3 s_i around the zero line, at their own scale.
    The view is an input of the state (in the link): the switch follows it, and the state follows the switch."""
    state = AppState()
    state.set_inputs({"m": 6, "horizon": 100.0, "extra_filters": ["kbf_adaptive"]})
    state.start()
    view = TrajectoriesView(state=state)
    run, traces = state.run, state.traces
    span = float(np.ptp(view._sources[0]["truth"].data["y"]))
    state.view = "errors"
    assert view._mode.value == "errors"
    for i in range(6):
        for name in ("kbf", "isl"):
            np.testing.assert_array_equal(view._sources[i][name].data["y"], traces.series[i][f"error:{name}"][1])
        np.testing.assert_array_equal(
            view._overlay._sources[i]["kbf_adaptive"].data["y"], traces.series[i]["error:kbf_adaptive"][1]
        )
        assert list(view._sources[i]["truth"].data["y"]) == [0.0, 0.0]  # the signal is the zero line
        band = view._bands[i]
        assert band.source is view._sources[i]["truth"]
        assert band.upper.transform.args["d"].value == pytest.approx(3 * run.s[i])
        lo, hi = view._figures[i].y_range.start, view._figures[i].y_range.end
        assert lo <= -3 * run.s[i] and hi >= 3 * run.s[i]
        assert hi - lo < 20 * run.s[i] * max(run.tracks[1].ratio[i], 1.0)  # the errors' scale, not the signal's
    assert view._figures[0].y_range.end - view._figures[0].y_range.start < span / 10
    assert view._legend.items[1].label.value == "X̂ᵢ − Xᵢ Kalman–Bucy"
    view._mode.value = "signal"  # and back, by the switch: the estimates in the tube around X̂
    assert state.view == "signal"
    np.testing.assert_array_equal(view._sources[0]["kbf"].data["y"], traces.series[0]["kbf"][1])
    assert view._bands[0].source is view._sources[0]["kbf"]


def test_a_links_extra_filters_are_drawn_by_lines_built_with_the_page():
    """Lines built when the first run arrives are added on the event loop, and each addition re-walked every model
    of the page (0.7 s of the loop at m = 6 with every filter): a link's filters get theirs with the page."""
    state = AppState(m=3, extra_filters=["kbf_minimax", "kbf_adaptive"])
    view = TrajectoriesView(state=state)
    before = [list(fig.renderers) for fig in view._figures]
    state.start()
    assert state.run is not None and [list(fig.renderers) for fig in view._figures] == before
    for i in range(3):
        for name in ("kbf_minimax", "kbf_adaptive"):
            lines = [r for r in view._figures[i].renderers if r.data_source.name == f"traj-{i + 1}-{name}"]
            assert len(lines) == 1 and lines[0].visible and len(lines[0].data_source.data["y"]) > 0


def _live_page_walks(view: TrajectoriesView, monkeypatch) -> list:
    """Start ``view``'s run, put its plots in a document, and count that document's re-walks of its models (one
    entry a walk) from then on."""
    from bokeh.document import Document

    view.state.start()
    doc = Document()
    for fig in [view._key_figure, *view._figures]:
        doc.add_root(fig)
    walks = []
    real = doc.models.recompute
    monkeypatch.setattr(doc.models, "recompute", lambda: walks.append(1) or real())
    return walks


def test_filters_ticked_on_a_live_page_rewalk_its_models_once(monkeypatch):
    view = TrajectoriesView(state=AppState(m=3))
    walks = _live_page_walks(view, monkeypatch)
    count = sum(len(fig.renderers) for fig in view._figures)
    view.state.baselines.extra_filters = ["kbf_minimax", "kbf_adaptive"]
    assert sum(len(fig.renderers) for fig in view._figures) == count + 2 * 3  # a line per filter and plot
    assert len(walks) == 1


def test_a_run_that_adds_no_line_does_not_rewalk_the_page(monkeypatch):
    view = TrajectoriesView(state=AppState(m=3, extra_filters=["kbf_minimax"]))
    walks = _live_page_walks(view, monkeypatch)
    view.state.sigma = 30.0  # a new run: data only
    assert view.state.run.model.sigma == 30.0 and walks == []


def test_the_tubes_edges_are_added_in_float64_to_the_drawn_line():
    """BokehJS's Dodge adds in the type of the line's array: in float32, at m = 6, β = 1000 (|X₁| up to 7.6·10¹⁰),
    the drawn half-widths were 4096–8192 around a 3 s₁ of 5526.6. The edges are the line's float32 values plus the
    offset in float64 (the browser test measures them to 1e-4 at that setting); the data stay float32."""
    state = AppState()
    state.set_inputs({"alpha": 0.01, "beta_from_w": False, "beta": 1000.0, "sigma": 933.0, "m": 6, "seed": 2})
    state.start()
    view = TrajectoriesView(state=state)
    for i in range(6):
        band, (up, down) = view._bands[i], view._dodges[i]
        assert view._sources[i]["kbf"].data["y"].dtype == np.float32
        assert band.upper.field == band.lower.field == "y"
        assert band.upper.transform.args == {"d": up} and band.lower.transform.args == {"d": down}
        assert band.upper.transform.v_func == band.lower.transform.v_func == EDGE and "Float64Array" in EDGE
        assert (up.value, down.value) == pytest.approx((3 * state.run.s[i], -3 * state.run.s[i]))
