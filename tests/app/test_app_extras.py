"""The dashboard's baselines (app.extras): extra filters on the run, their inputs, the worst-case table.

Headless: no server, no browser. Jobs run inline unless a test gives the state a thread pool.
"""

import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from _loop import ManualLoop

from app import extras
from app.extras import EXTRA_NAMES
from app.jobs import Jobs, LongJobQueue
from app.state import AppState, declaration
from app.views.numbers import numbers_html
from app.views.worstcase import WorstCaseView, worst_case_html
from isl_core import WORST_CASE_FILTERS as FILTERS
from isl_core import Model, baseline_filters, simulate, theory_ratios
from isl_core.decimate import minmax_indices
from isl_core.filters.baselines import LABELS


@pytest.fixture
def state():
    s = AppState()
    s.start()
    return s


def test_default_run_has_only_the_two_filters(state):
    assert [tr.name for tr in state.run.tracks] == ["kbf", "isl"] and state.extra_prediction == {}
    assert "other filters" not in numbers_html(state.run, state.prediction, 0.0, state.extra_prediction)


def test_extra_filters_ride_on_the_same_run(state):
    state.baselines.extra_filters = list(extras.EXTRA_NAMES)
    run = state.run
    assert [tr.name for tr in run.tracks] == ["kbf", "isl", *extras.EXTRA_NAMES] and state.message == ""
    # the same noise: an independent simulate with the same filters, grid and seed reproduces every track
    specs = baseline_filters(
        run.model,
        nu=run.nu,
        sigma_design=state.baselines.sigma_design,
        sigma_range=state.baselines.sigma_range,
        names=extras.EXTRA_NAMES,
    )
    again = simulate(run.model, run.nu, T=run.T, h=run.h, seed=run.seed, extra=specs)
    for a, b in zip(run.tracks, again.tracks, strict=True):
        for i in range(run.model.m):
            np.testing.assert_array_equal(a.estimate[i].y, b.estimate[minmax_indices(b.estimate[:, i]), i])
    assert run.track("kbf_adaptive").sigma_hat is not None
    # traces for every filter and its error, theory per filter (the mismatched KBF for σ̄ = σ = 20 is the oracle)
    names = {"truth", "kbf", "isl", *extras.EXTRA_NAMES}
    assert set(state.traces.series[0]) == names | {f"error:{n}" for n in names - {"truth"}}
    np.testing.assert_allclose(state.extra_prediction["kbf_mismatched"], 1.0, rtol=1e-9)
    assert np.all(np.isnan(state.extra_prediction["kbf_adaptive"]))
    np.testing.assert_array_equal(state.extra_prediction["isl_model"], theory_ratios(run.model, specs[-1]))
    html = numbers_html(run, state.prediction, 0.0, state.extra_prediction)
    assert "other filters" in html and all(tr.label in html for tr in run.tracks[2:])


def test_design_sigma_and_range_reach_the_filters(state):
    state.baselines.extra_filters = ["kbf_mismatched", "kbf_minimax"]
    state.set_inputs({"sigma_design": 5.0, "sigma_max": 100.0})
    assert "5" in state.run.track("kbf_mismatched").label and "100" in state.run.track("kbf_minimax").label
    model = state.run.model
    (spec,) = baseline_filters(model, nu=3.0, sigma_design=5.0, names=("kbf_mismatched",))
    np.testing.assert_array_equal(state.extra_prediction["kbf_mismatched"], theory_ratios(model, spec))


@pytest.mark.parametrize(
    "name, bad",
    [
        ("sigma_design", float("nan")),
        ("sigma_design", 0.0),
        ("sigma_design", "20"),
        ("sigma_design", 1e308),
        ("sigma_min", 500.0),
        ("sigma_min", -1.0),
        ("sigma_max", 1.0),
        ("sigma_max", None),
        ("extra_filters", ["kbf"]),
        ("extra_filters", "isl_model"),
        ("extra_filters", ["isl_model", "isl_model"]),
        ("wc_alphas", []),
        ("wc_alphas", [0.0]),
        ("wc_n_sigma", 1),
        ("wc_horizon", float("inf")),
    ],
)
def test_bad_values_are_refused_with_a_message(state, name, bad):
    state.baselines.extra_filters = ["isl_model"]
    run, before = state.run, state.get(name)
    state.set(name, bad)
    assert state.get(name) == before and state.run is run
    label = declaration(name).label
    assert state.message.startswith("Refused: ") and label in state.message and " must be " in state.message


def test_sigma_range_needs_min_below_max(state):
    state.set("sigma_min", 200.0)
    assert state.baselines.sigma_min == 2.0 and "σ min (sigma_min) must be below σ max (sigma_max)" in state.message
    assert "sigma_min" in state.refusals
    state.set_inputs({"sigma_max": 300.0, "sigma_min": 250.0})  # judged with both ends as they will be
    assert state.baselines.sigma_range == (250.0, 300.0) and state.refusals == {}


def test_sweep_curves_of_the_extra_filters(state):
    state.sweep.want_curves()
    assert state.sweep.curves is not None, state.sweep.curves_note
    assert state.sweep.curves.extra == {}
    state.baselines.extra_filters = list(extras.EXTRA_NAMES)
    extra = state.sweep.curves.extra
    assert set(extra) == {"kbf_mismatched", "kbf_minimax", "isl_model"}  # no theory for the adaptive filter
    assert extra["isl_model"].shape == state.sweep.curves.ratios.shape
    assert np.ptp(extra["kbf_minimax"], axis=1).max() == 0.0  # a fixed gain does not depend on ν


def test_worst_case_table_is_computed_off_thread_and_shown():
    loop, pool = ManualLoop(), ThreadPoolExecutor(max_workers=1)
    try:
        s = AppState(jobs=Jobs({"run": pool, "theory": pool}, schedule=loop.schedule, long_queue=LongJobQueue()))
        s.start()
        s.set_inputs({"wc_alphas": [1.0], "wc_n_sigma": 2, "wc_horizon": 20.0})
        view = WorstCaseView(state=s)
        assert not view._figure.visible and "No table yet" in view._table.object  # nothing to plot yet
        caller = threading.get_ident()
        s.worstcase.compute()
        assert s.worstcase.busy  # returned before the table exists: the work is in the long-job queue
        loop.pump(lambda: not s.worstcase.busy, timeout=120.0)
        assert threading.get_ident() == caller
        t = s.worstcase.table
        assert t is not None and "Simulated" in s.worstcase.note, s.worstcase.note
        assert t.alphas.tolist() == [1.0] and t.sigma_range == (2.0, 200.0) and t.names == FILTERS
        # internal consistency: each worst case is the largest per-σ value, the oracle's theory is 1
        assert np.all(t.worst[0] >= t.ratio[0].max(axis=-1).max(axis=0) - 1e-12)
        assert t.theory_worst[0, 0] == pytest.approx(1.0, rel=1e-9)
        html = worst_case_html(t)
        assert "α = 1" in html and all(label in html for label in t.labels)
        assert view._figure.visible and view._table.object == html
        dots = {name: list(src.data["y"]) for name, src in view._sources.items()}
        assert dots == {name: [t.worst[0, f]] for f, name in enumerate(t.names)}  # one dot per filter at α = 1
    finally:
        pool.shutdown(wait=True)


def test_worst_case_can_be_cancelled():
    loop, pool = ManualLoop(), ThreadPoolExecutor(max_workers=1)
    try:
        s = AppState(jobs=Jobs({"run": pool, "theory": pool}, schedule=loop.schedule, long_queue=LongJobQueue()))
        s.start()
        s.set_inputs({"wc_alphas": [0.04, 25.0], "wc_horizon": 2000.0})  # long enough to be caught running
        s.worstcase.compute()
        s.worstcase.cancel()
        loop.pump(lambda: not s.worstcase.busy, timeout=120.0)
        assert s.worstcase.note == "Cancelled." and s.worstcase.table is None
    finally:
        pool.shutdown(wait=True)


def test_worst_case_model_is_the_papers_parametrization():
    # the table's β per α is w√(2α) (A.25), with the state's w
    t = extras.worst_case_table(
        [0.5], sigma_range=(2.0, 20.0), n_sigma=2, m=2, w=2.0, sigma_design=6.0, horizon=20.0, seed=3
    )
    rec = t.records()
    assert rec[0]["beta"] == pytest.approx(Model.from_w(0.5, 2.0, 2.0, 2).beta)
    assert t.sigma_design[0, t.names.index("kbf_mismatched")] == 6.0 and t.seeds == (3,)


def test_sweep_view_draws_the_extra_curves(state):
    from app.views.sweep import SweepView

    state.sweep.want_curves()
    assert state.sweep.curves is not None, state.sweep.curves_note
    view = SweepView(state=state)
    srcs = view._extra_lines[0]
    assert all(len(src.data["x"]) == 0 for name in srcs for src in srcs[name])
    state.baselines.extra_filters = ["isl_model", "kbf_adaptive"]
    n = len(state.sweep.sigmas)
    assert [len(src.data["x"]) > 0 for src in srcs["isl_model"]] == [True] * n + [False] * (len(srcs["isl_model"]) - n)
    assert LABELS["isl_model"] in view._extra_legend.object and LABELS["kbf_minimax"] not in view._extra_legend.object
    np.testing.assert_array_equal(srcs["isl_model"][0].data["y"], state.sweep.curves.extra["isl_model"][0, :, 0])


def test_sweep_note_at_alpha_zero_says_the_curves_coincide_and_why_no_recommendation(state):
    from app.views.sweep import SweepView

    view = SweepView(state=state)

    def note() -> str:
        return view._note(state.sweep.note, state.sweep.curves_note, state.sweep.points, state.sweep.curves)

    assert state.alpha > 0 and "coincide" not in note() and "needs α > 0" not in note()
    state.alpha = 0.0  # paper B: the ratio depends on ν/β only
    assert state.sweep.curves.alpha == 0.0 and len(state.sweep.curves.sigmas) == 3
    assert "coincide" in note() and "needs α > 0" in note()
    state.sweep.sigmas = [20.0]
    assert "coincide" not in note()  # one σ: nothing to coincide with


def test_trajectories_overlay_the_extra_filters(state):
    from app.views.trajectories import TrajectoriesView

    view = TrajectoriesView(state=state)
    srcs = view._overlay._sources
    items = dict(zip(EXTRA_NAMES, view._overlay.items, strict=True))  # one legend item per extra filter
    lines = {n: view._overlay._followers[n] for n in EXTRA_NAMES}  # the filter's line in each plot
    assert all(len(src.data["t"]) == 0 for per_plot in srcs for src in per_plot.values())  # default: nothing sent
    assert not any(item.visible for item in items.values()) and not any(ln.visible for v in lines.values() for ln in v)
    state.baselines.extra_filters = ["kbf_adaptive", "isl_model"]
    for i in range(state.m):
        _, y = state.traces.series[i]["isl_model"]
        np.testing.assert_array_equal(srcs[i]["isl_model"].data["y"], y)
        assert len(srcs[i]["kbf_adaptive"].data["t"]) > 0 and "kbf_minimax" not in srcs[i]  # built when first shown
    assert items["isl_model"].visible and items["kbf_adaptive"].visible and not items["kbf_minimax"].visible
    assert all(ln.visible for ln in lines["isl_model"]) and not any(ln.visible for ln in lines["kbf_minimax"])
    state.baselines.extra_filters = []
    assert all(len(src.data["t"]) == 0 for per_plot in srcs for src in per_plot.values())


def test_the_numbers_give_the_measured_share_of_time_in_the_tube_beside_the_theory(state):
    import re

    html = numbers_html(state.run, state.prediction, 0.0, state.extra_prediction)
    assert "measured (theory 99.7 %)" in html
    shares = [float(x) for x in re.findall(r"<td>([0-9.]+) %</td>", html)]
    assert len(shares) == state.m  # one per coordinate, the optimal filter's
    assert shares == [pytest.approx(100 * x, abs=0.05) for x in state.run.tracks[0].inside]
    assert all(85.0 <= x <= 100.0 for x in shares)  # a 10/r_min run: near 99.7 %, never far below
