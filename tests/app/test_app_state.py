"""The dashboard state (app.state): presets, one new run per change, refused inputs, background jobs.

Headless: no server, no browser. Jobs run inline unless a test gives the state thread pools.
"""

import math
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from _loop import ManualLoop

from app import pipeline
from app.jobs import Jobs, LongJobQueue
from app.pipeline import APP_MAX_STEPS
from app.presets import PAPER_PRESETS
from app.state import INPUTS, AppState
from app.state import session as state_module
from isl_core import DivergenceError, Model, kalman_bucy, recommend_nu


@pytest.fixture
def state():
    s = AppState()
    s.start()
    return s


def test_starts_at_paper_a_fig3(state):
    run = state.run
    assert run.model == Model(0.5, 3.0, 20.0, 3) and run.nu == 3.0
    assert math.isclose(run.T * run.r_min, 10.0, rel_tol=1e-12)
    assert state.message == ""


@pytest.mark.parametrize("sigma", [20.0, 200.0])
def test_fig3_presets(state, sigma):
    state.apply_preset(f"Fig. 3, σ = {sigma:g}")
    run = state.run
    # paper A, Fig. 3: m = 3, α = 0.5, w = 3 → β = w√(2α) = 3, ν = β, T = 10/r_min (:ref:`reference-values`)
    assert run.model == Model.from_w(0.5, 3.0, sigma, 3) and run.model.beta == 3.0
    assert run.nu == 3.0 and math.isclose(run.T * run.r_min, 10.0, rel_tol=1e-12)


@pytest.mark.parametrize("sigma, sqrt_q11", [(5.0, 6.49), (50.0, 44.2)])
def test_paper_b_presets(state, sigma, sqrt_q11):
    state.apply_preset(f"Paper B, Fig. 2 (α = 0, σ = {sigma:g})")
    run = state.run
    assert run.model == Model(0.0, 3.0, sigma, 3) and run.nu == 3.0  # (B.25–B.26): ν = β
    # the tube half-width's s_1 = √Q_11 is printed in paper B to 3 digits (:ref:`reference-values`)
    assert round(float(run.s[0]), 2 if sigma == 5.0 else 1) == sqrt_q11


def test_white_noise_preset_has_the_b52_theory(state):
    state.apply_preset("White-noise model m = 1")
    assert state.run.model.m == 1 and state.run.model.alpha == 0.0 and state.run.nu == state.run.model.beta
    if state.prediction is not None:  # theory module installed
        assert state.prediction[0] == pytest.approx((math.pi / 2) ** 0.25, rel=1e-10)  # (B.52)


def test_unknown_preset_is_a_message(state):
    run = state.run
    state.apply_preset("no such preset")
    assert "Unknown preset" in state.message and state.run is run


CHANGES = {
    "alpha": 1.0,
    "beta_from_w": False,
    "w": 2.0,
    "beta": 5.0,
    "sigma": 50.0,
    "nu": 1.5,
    "m": 2,
    "seed": 7,
    "horizon": 20.0,
}


def _expected(s: AppState):
    beta = s.w * math.sqrt(2 * s.alpha) if s.beta_from_w else s.beta
    return Model(s.alpha, beta, s.sigma, s.m), s.nu, s.seed, s.horizon


@pytest.mark.parametrize("name", INPUTS)
def test_every_change_gives_a_new_run(state, name):
    if name == "beta":
        state.beta_from_w = False
    before = state.run
    setattr(state, name, CHANGES[name])
    run = state.run
    assert run is not before
    model, nu, seed, horizon = _expected(state)
    assert run.model == model and run.nu == nu and run.seed == seed
    assert run.stretch >= 1.0  # T = horizon/r_min, lengthened where the ISL filter settles slower (B.46)
    assert math.isclose(run.T * run.r_min, horizon * run.stretch, rel_tol=1e-12)
    assert state.traces is not None and len(state.traces.series) == model.m


BAD = [float("nan"), float("inf"), -float("inf"), -1.0, 1e308, "x", None, True, [1.0], 1 + 2j]


@pytest.mark.parametrize("name", [n for n in INPUTS if n != "beta_from_w"])
@pytest.mark.parametrize("bad", BAD, ids=repr)
def test_bad_values_are_refused_with_a_message(state, name, bad):
    """From outside (a widget, a link, a script's set), a bad value is refused in words beside its input; assigned in
    code, it is param's own refusal, a ValueError that names the parameter."""
    run, value = state.run, getattr(state, name)
    with pytest.raises(ValueError, match=f"parameter 'AppState.{name}'"):
        setattr(state, name, bad)
    assert state.run is run and getattr(state, name) == value and state.message == ""
    state.set(name, bad)
    assert state.run is run and getattr(state, name) == value
    assert state.message_kind == "danger"
    label = state.param[name].label
    assert state.message.startswith(f"Refused: {label} must be a ")  # names the input and its range, in words
    assert " from " in state.message and "type" not in state.message and "None" not in state.message


@pytest.mark.parametrize("bad", ["true", 1, None, float("nan")], ids=repr)
def test_bad_switch_values_are_refused(state, bad):
    run = state.run
    state.set("beta_from_w", bad)
    assert state.run is run and state.beta_from_w is True
    assert state.message.startswith("Refused: β from w must be on or off (true or false)")


def test_scripted_batch_update_keeps_the_good_values(state):
    state.set_inputs({"sigma": float("nan"), "nu": 1.5})
    assert "σ must be a number from 0.1 to 1000; nan is not a finite number" in state.message
    assert state.sigma == 20.0 and state.run.nu == 1.5  # the good value of the batch is applied


def test_a_good_change_clears_the_message(state):
    state.set("sigma", "x")
    assert state.message
    state.sigma = 30.0
    assert state.message == "" and state.run.model.sigma == 30.0


def test_too_many_steps_is_refused_at_the_horizon_which_returns_to_the_run_on_screen(state):
    state.param.update(alpha=25.0, sigma=200.0)  # h is tiny here: 1000/r_min needs millions of steps
    run = state.run
    state.horizon = 1000.0
    assert state.run is run and "steps" in state.message and f"{APP_MAX_STEPS:,}" in state.message
    assert state.horizon == 10.0 and state.run_inputs() == state.shown_inputs  # every input is the run's again
    assert set(state.refusals) == {"horizon"} and "horizon (× 1/rₘᵢₙ) = 1000" in state.refusals["horizon"]


@pytest.mark.parametrize("path", ["code", "widget"])
def test_a_value_refused_only_with_the_others_is_refused_at_the_input_just_moved(state, path):
    """α = 100 is in range, σ = 741 too; together (at horizon 10) the run needs ~3 million steps: α goes back to the
    run on screen's, the refusal stands beside α, names it and says so in the page's message — whether α was set in
    code or came through the widgets' boundary (which must not lift the refusal the run has just made)."""
    state.sigma = 741.0
    run, alpha = state.run, state.alpha
    if path == "code":
        state.alpha = 100.0
    else:
        assert state.set("alpha", 100.0)  # taken: the run refuses it afterwards
    assert state.run is run and state.alpha == alpha and state.run_inputs() == state.shown_inputs
    assert set(state.refusals) == {"alpha"} and state.refusals["alpha"] == state.message
    assert "α = 100" in state.message and f"α is back at {alpha:g}" in state.message
    assert not state.message_inline  # also in the sidebar's summary
    state.alpha = 0.6  # a good value lifts the refusal
    assert state.refusals == {} and state.run.model.alpha == 0.6


def test_a_refused_runs_message_ends_with_the_next_run_whatever_input_starts_it(state):
    """After α = 100 with σ = 741 is refused (α back at the run on screen's), a good run started by σ replaces that
    run: the refusal, which says α is back at the run on screen, goes with it (and blocks nothing any more)."""
    state.sigma = 741.0
    state.alpha = 100.0
    assert set(state.refusals) == {"alpha"}
    state.sigma = 30.0
    assert state.run.model.sigma == 30.0 and state.refusals == {} and state.message == ""


def test_core_divergence_is_a_message(state, monkeypatch):
    def diverge(*args, **kwargs):
        raise DivergenceError("filter ISL diverged at t = 1")

    monkeypatch.setattr(pipeline, "simulate_view", diverge)
    run = state.run
    state.seed = 99
    assert state.run is run and "diverged" in state.message and state.message_kind == "danger"


@pytest.mark.parametrize("change", [{}, {"horizon": 1000.0}, {"m": 6, "nu": 10_000.0, "sigma": 1.0, "horizon": 5000.0}])
def test_the_dashboards_run_is_the_cores_run_on_the_cores_own_grid(state, change):
    """The pipeline hands its planned step to the simulation (sparing a second step-size search); the run must be the
    one the core chooses by itself, bit for bit — also for a horizon lowered to fit the step limit, N close to 10⁶."""
    import dataclasses

    from isl_core.runview import simulate_view

    result = pipeline.compute(dataclasses.replace(state.request(), **change), nearest=True)
    req = result.request
    model, extra, every, _ = pipeline.plan(req)
    own = simulate_view(model, req.nu, horizon=req.horizon, seed=req.seed, extra=extra, step_filters=every)
    run = result.run
    assert (run.N, run.h, run.T, run.stretch) == (own.N, own.h, own.T, own.stretch)
    for mine, theirs in zip(run.tracks, own.tracks, strict=True):
        assert all(
            np.array_equal(a.y, b.y) and np.array_equal(a.t, b.t)
            for a, b in zip(mine.estimate, theirs.estimate, strict=True)
        )
    assert ("horizon lowered" in result.adjusted) == ("horizon" in change and change["horizon"] == 5000.0)


def test_alpha_zero_in_w_mode_switches_to_beta(state):
    state.alpha = 0.0
    assert state.beta_from_w is False and state.beta == 3.0  # β of the last run, now set directly
    assert state.run.model == Model(0.0, 3.0, 20.0, 3)


def test_sweep_sigmas_are_validated_and_sorted(state):
    state.set("sweep_sigmas", [200, 2.0, 20])
    assert state.sweep.sigmas == [2.0, 20.0, 200.0]
    for bad in (["a"], [], [1.0] * 6, "2, 20", [0.0], [float("nan")]):
        with pytest.raises(ValueError, match=r"parameter 'SweepRoom\.sigmas'"):
            state.sweep.sigmas = bad
        state.set("sweep_sigmas", bad)
        assert state.sweep.sigmas == [2.0, 20.0, 200.0]
        assert state.message.startswith("Refused: σ values must be a list of 1 to 5 numbers from 0.1 to 1000; ")


def test_csv_holds_the_run_its_parameters_and_its_numbers(state):
    from app.export import MAX_ROWS
    from isl_core import simulate

    state.baselines.extra_filters = ["kbf_adaptive"]
    text = state.csv().getvalue()
    lines = text.splitlines()
    head = "\n".join(line for line in lines if line.startswith("#"))
    assert lines[0].startswith("# isl run export; isl ") and "seed=1" in head
    for needle in (
        "m=3 alpha=0.5 beta=3 sigma=20 (beta = w*sqrt(2*alpha), w=3)",
        "nu=3 (nu/beta=1)",
        "horizon: asked 10/r_min",
        "r_min=",
        "T=",
        "h=",
        "N=",
        "every 1 step(s)",
        "e0 ~ N(0, Delta)",
        "kbf_adaptive = Kalman–Bucy, adaptive",
    ):
        assert needle in head, needle
    columns = next(line for line in lines if line.startswith("# t,"))[2:].split(",")
    assert columns[:4] == ["t", "X1_position", "X2_velocity", "X3_acceleration"]
    assert columns[4] == "reading" and columns[-1] == "kbf_adaptive_X3_acceleration" and len(columns) == 2 + 3 * 4
    data = np.loadtxt(lines, delimiter=",", comments="#")
    view = state.run
    extra, grid = pipeline.extra_filters(state.shown_request, view.model)
    run = simulate(
        view.model, view.nu, horizon=state.horizon, seed=view.seed, extra=extra, step_filters=grid, readings=True
    )
    assert data.shape == (view.N + 1, len(columns))  # the same run, every step
    expected = np.column_stack([run.t, run.X, run.readings, *(tr.estimate for tr in run.tracks)])
    np.testing.assert_allclose(data, expected, rtol=1e-8, atol=1e-12 * np.nanmax(np.abs(expected)))
    ratios = next(line for line in lines if line.startswith("# X1_position: s="))
    assert f"kbf {view.ratio_hat[0]:.6g} (1)" in ratios and f"isl {view.ratio_check[0]:.6g}" in ratios
    state.horizon = 1000.0  # ≈ 10⁵ steps: every k-th row only
    data = np.loadtxt(state.csv().getvalue().splitlines(), delimiter=",", comments="#")
    assert len(data) <= MAX_ROWS and data[-1, 0] <= state.run.T


def test_traces_are_small_and_real_samples(state):
    state.horizon = 1000.0  # Fig. 3 defaults: about 10⁵ steps
    run, traces = state.run, state.traces
    assert run.N > 10 * 2400
    for i, series in enumerate(traces.series):
        t, y = series["isl"]
        assert len(t) <= 2400 and t.dtype == np.float32
        k = np.clip(np.rint(t.astype(float) / run.h).astype(int), 0, run.N)
        tol = np.finfo(np.float32).eps * run.T  # float32 copies of the run's grid times
        assert np.max(np.abs(k * run.h - t)) <= tol and np.all(np.abs(k * run.h - t) < run.h / 2)
        assert y.max() == np.float32(run.track("isl").estimate[i].y.max())  # float32 copies of the envelope


def test_theory_curves_follow_the_context(state):
    state.sweep.want_curves()
    assert state.sweep.curves is not None, state.sweep.curves_note
    assert state.sweep.curves.ratios.shape == (3, 81, 3)
    state.m = 2
    assert state.sweep.curves.m == 2 and state.sweep.curves.ratios.shape == (3, 81, 2)
    kb = kalman_bucy(Model(0.5, 3.0, 20.0, 2))
    assert kb.r_min > 0  # the context change did not disturb the run


def test_threaded_runs_coalesce_to_the_latest_request():
    loop, pool = ManualLoop(), ThreadPoolExecutor(max_workers=2)
    gate, computed = threading.Event(), []
    real = state_module.compute

    def gated(req, **kw):
        gate.wait(30)
        computed.append(req.sigma)
        return real(req, **kw)

    try:
        s = AppState(jobs=Jobs({"run": pool, "theory": pool}, schedule=loop.schedule))
        s.start()
        assert s.run is None and s.computing and s.busy  # the first run is a job too: the page shows "busy"
        loop.pump(lambda: s.run is not None and not s.computing)
        state_module.compute = gated
        for sigma in (21.0, 22.0, 23.0, 24.0):
            s.sigma = sigma
        assert s.computing
        gate.set()
        loop.pump(lambda: not s.computing)
        assert computed == [21.0, 24.0]  # the first (in flight) and the latest; 22 and 23 never ran
        assert s.run.model.sigma == 24.0
    finally:
        state_module.compute = real
        pool.shutdown(wait=True)


def test_threaded_sweep_can_be_cancelled():
    loop, pool = ManualLoop(), ThreadPoolExecutor(max_workers=2)
    try:
        s = AppState(jobs=Jobs({"run": pool, "theory": pool}, schedule=loop.schedule, long_queue=LongJobQueue()))
        s.start()
        s.set_inputs({"sweep_horizon": 2000.0, "alpha": 25.0})  # long enough to be caught running
        s.sweep.simulate()
        assert s.sweep.busy
        s.sweep.cancel()
        loop.pump(lambda: not s.sweep.busy)
        assert s.sweep.note == "Cancelled." and s.sweep.points is None
    finally:
        pool.shutdown(wait=True)


def test_inline_sweep_gives_points_with_intervals(state):
    state.set_inputs({"sweep_sigmas": [20.0], "sweep_horizon": 50.0})
    state.sweep.simulate()
    pts = state.sweep.points
    assert pts is not None and pts.ratio.shape == (1, 11, 3) and np.all(pts.high > pts.low)
    assert pts.sigmas == (20.0,) and "Simulated" in state.sweep.note
    state.alpha = 1.0  # another context: the points are stale and dropped, and the note that reported them
    assert state.sweep.points is None and state.sweep.note == ""


def test_a_recommendation_note_goes_with_its_context(state):
    state.set_inputs({"sweep_sigmas": [2.0, 200.0], "sweep_horizon": 20.0})
    state.sweep.recommend()
    assert state.sweep.note.startswith("Recommended ν")
    state.seed = 5  # not part of the sweep's context: the note stays
    assert state.sweep.note.startswith("Recommended ν")
    state.m = 2
    assert state.sweep.note == ""


def test_close_drops_the_run(state):
    state.close()
    assert state.run is None and state.traces is None


def test_every_preset_is_valid(state):
    for name in PAPER_PRESETS:
        state.apply_preset(name)
        assert state.message in ("",) or state.message_kind == "info", (name, state.message)


def test_recommendation_sets_nu(state):
    state.set_inputs({"sweep_sigmas": [2.0, 200.0], "sweep_horizon": 20.0})
    state.sweep.recommend()
    assert state.sweep.note.startswith("Recommended ν"), state.sweep.note
    rec = recommend_nu(0.5, sigmas=[2.0, 200.0], m=3, w=3.0, verify=False)
    assert state.nu == pytest.approx(rec.nu, rel=1e-12)  # the core's answer, not a copy of table (A.31)


def test_recommendation_needs_alpha_positive(state):
    state.alpha = 0.0
    nu = state.nu
    state.sweep.recommend()
    assert "alpha > 0" in state.sweep.note and state.nu == nu


def test_create_app_builds_a_page_outside_a_server():
    import panel as pn

    from app.app import create_app

    page = create_app()
    assert isinstance(page, pn.template.FastListTemplate)
    assert len(page.main) == 1 and len(page.sidebar) == 3
    tabs = page.main[0][0]
    for view in (*page.sidebar, *tabs):  # every view renders to bokeh models without a warning
        assert pn.panel(view).get_root() is not None


def test_at_alpha_zero_the_alpha_slider_shows_no_number(state):
    """Its scale is log α: at α = 0 it used to read 0.01, its end. It now shows no value and says α = 0."""
    from app.views import ControlsView

    view = ControlsView(state=state)
    state.alpha = 0.0
    slider = view._alpha
    assert slider.disabled and not slider.show_value and slider.name.endswith("= 0 (ticked below)")
    state.alpha = 0.5
    assert not slider.disabled and slider.show_value and "= 0" not in slider.name


def test_the_figure_download_draws_the_run_on_screen_with_the_clis_renderer(state, monkeypatch):
    """One renderer for exported figures: the dashboard's PNG comes from app.static_figures.fig3_png, as isl
    figure3's does, with every coordinate, the legend and the parameters."""
    from app import static_figures

    drawn = []
    original = static_figures.fig3_png
    monkeypatch.setattr(
        static_figures, "fig3_png", lambda views, path, **kw: drawn.append((views, kw)) or original(views, path, **kw)
    )
    png = state.png().getvalue()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000
    ((views, kw),) = drawn
    assert views == [state.run] and "measured RMSE/s_i" in kw["note"]
    lines = static_figures._fig3_lines(state.run, 0)
    assert [label for label, *_ in lines][:4] == [
        "X (truth)",
        "X̂ (Kalman–Bucy, knows σ)",
        "X̌ (ISL, σ unknown)",
        "X̂ ± 3s (optimal RMSE)",
    ]
    assert f"m = {state.m}" in static_figures._fig3_title(state.run)


def test_the_compare_view_draws_the_run_beside_the_same_run_at_another_sigma(state):
    """Paper A's Fig. 3 pair: σ = 20 | σ = 200, the same seed and inputs; the left column is the run on screen."""
    from app.views.compare import CompareView

    view = CompareView(state=state)
    assert view.sigma_b == 200.0 and view._image.object is None  # drawn on request only
    view.draw()
    png, table = view._image.object, view._table.object
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert "σ = 20<" in table and "σ = 200<" in table
    on_screen = f"{state.run.tracks[0].ratio[0]:.3f} / {state.run.tracks[1].ratio[0]:.3f}"
    assert on_screen in table  # the left column is the run on screen, bit for bit
    state.nu = 1.5
    assert "has changed since this picture" in view._note.object
