"""A property of the page, driven by random sequences of actions: after every action, what BokehJS has computed —
every tube's drawn offsets, every line's arrays, every legend label of the trajectory plots, the scenario legend, and
the value every model control holds — is what the run the page's link describes says.

The actions are what a class does: the paper's presets, slider keys on α, σ, ν and m, the error view, the other
filters, new noise, the scenario presets (which set α, σ and ν too) — and what it should not be able to break: a
slider pushed to an end the other inputs refuse (α = 100 at σ = 200 needs millions of steps), a refused number typed
in the seed box, Back and Forward. Back and Forward reopen the page at the link they reach, on the tab that link
names: a link left on the Scenarios tab (a scenario preset is chosen there) reopens that tab, whose legend must name
the link's run, and the test then goes back to the trajectories. The expected values are recomputed here from the link
(the same request through the core), so the check holds for the run the page says it shows.

Each run replays the sequences of :data:`SEEDS`, each to its length there (the test's id names the seed);
``ISL_PROPERTY_SEED=random`` explores one fresh sequence instead, and an integer replays that one (to its length in
:data:`SEEDS`, else :data:`DEFAULT_ACTIONS`). ``ISL_PROPERTY_ACTIONS`` sets every sequence's length. A failure
names the seed, the last actions, the page's address and what the page and the server logged.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import random
import time
import urllib.parse

import numpy as np
import pytest
from _browser import BAND_OFFSETS, PLOT_DATA, SCENARIO_TEXT, TAB_OPEN, dashboard

from app.page import TAB_TITLES
from app.pipeline import APP_MAX_STEPS, compute, plan
from app.state import AppState, declaration
from app.state.scenarios import PRESETS as SCENARIO_PRESETS
from app.urlsync import parse_query
from app.views.trajectories import KEY_LABELS, shown_series
from isl_core import Model, kalman_bucy
from isl_core.filters.baselines import LABELS

pytestmark = [pytest.mark.browser]

#: the sequences every run replays, and how many actions each: seed 0, and three that go Back onto a link left on the
#: Scenarios tab — 359 at its 7th action, 299 at its 14th, 313 at its 18th — each replayed three actions past that
SEEDS = {0: 40, 359: 10, 313: 21, 299: 17}
BACK_ONTO_SCENARIOS = (359, 313, 299)  #: of those, the sequences that must go Back onto that link within their length
DEFAULT_ACTIONS = 40  #: of a sequence ``ISL_PROPERTY_SEED`` names that :data:`SEEDS` does not
ACTIONS = os.environ.get("ISL_PROPERTY_ACTIONS")  #: every sequence's, if set
TRAJECTORIES = TAB_TITLES["trajectories"]
SCENARIOS = TAB_TITLES["scenarios"]
SLIDERS = {
    "alpha": "α, damping of the top derivative",
    "sigma": "σ, observation noise intensity",
    "nu": "ν, the ISL filter's tuning knob",
    "m": "m, state dimension",
}
PRESET_BUTTONS = ("Fig. 3, σ = 20", "Fig. 3, σ = 200")
#: the sliders' ends a class may push to (End): refused when the run they ask for needs too many steps
ENDS = {"alpha": 100.0, "sigma": 1000.0, "horizon": 1000.0}
#: typed in the seed box: each refused (below the range, not whole, too long for a float, out of range)
BAD_SEEDS = ("-5", "1.5", "1e400", "9" * 400, "3000000000")
#: the model controls as BokehJS holds them: slider values (log10 of the input's for α, σ, ν, horizon) and the seed box
CONTROLS = """(titles) => { const models = Array.from(Bokeh.documents[0].all_models);
    return Object.fromEntries(Object.entries(titles).map(([key, title]) => {
        const m = models.find(m => (m.type === 'Slider' || m.type === 'Spinner') && m.title === title);
        return [key, m ? m.value : null]; })); }"""
CONTROL_TITLES = {k: declaration(k).label for k in ("alpha", "sigma", "nu", "m", "horizon", "seed")}
CONTROL_TITLES["m"] = "m (state dimension)"
EXTRA_BOXES = ("KBF for mid σ", "KBF adaptive", "ISL model-aware")

#: what BokehJS holds for the trajectory plots: each band's [source, points, min/max of its drawn upper and lower
#: offsets], each line source's arrays (t, y) and the labels of the legend items it shows
DRAWN = (
    """() => { const KEYS = ["Xᵢ signal", "0 (no error)"];
    const views = Array.from(Bokeh.index.all_views());
    const bands = ("""
    + BAND_OFFSETS
    + """)();
    const lines = {};
    for (const v of views) {
        const src = v.model.data_source;
        if (v.model.type === 'GlyphRenderer' && v.model.visible && src && /^traj-\\d-/.test(src.name || '')
                && src.data.y && src.data.y.length > 0)
            lines[src.name] = [Array.from(src.data.t), Array.from(src.data.y)];
    }
    const labels = [];  // the key: the legend that names the signal's line (a plot of its own above the three)
    for (const v of views.filter(v => v.model.type === 'Figure'))
        for (const l of [...v.model.right, ...v.model.above, ...v.model.below, ...v.model.center, ...v.model.left])
            if (l.type === 'Legend' && l.items.some(i => KEYS.includes(i.label.value)))
                for (const i of l.items) if (i.visible !== false) labels.push(i.label.value);
    return {bands, lines, labels: Array.from(new Set(labels)).sort()};
}"""
)
assert all(label in DRAWN for label in KEY_LABELS["truth"])  # the key is found by the signal's label, in either view

#: the scenario plots' legend labels as BokehJS holds them
SCENARIO_LABELS = f"() => ({SCENARIO_TEXT})().flatMap(f => f[1])"


def expected(url: str) -> dict:
    """What the trajectory plots must show for the run ``url`` describes: the core's 3 sᵢ per band, the run's arrays
    per line source (the view's series), the legend labels."""
    state = AppState()
    state.set_inputs(parse_query(urllib.parse.urlsplit(url).query))
    req = state.request()
    result = compute(req, nearest=True)
    run = result.run
    errors = state.view == "errors"
    s = np.sqrt(np.diag(kalman_bucy(Model(req.alpha, req.beta, req.sigma, req.m)).delta))
    bands = {f"traj-{i + 1}-{'truth' if errors else 'kbf'}": 3.0 * float(s[i]) for i in range(req.m)}
    lines = {}
    for i in range(req.m):
        for name, (t, y) in shown_series(result.traces.series[i], errors, run.T).items():
            if name in ("truth", "kbf", "isl") or name in req.extras:
                lines[f"traj-{i + 1}-{name}"] = (np.asarray(t, np.float32), np.asarray(y, np.float32))
    labels = sorted({KEY_LABELS[k][errors] for k in ("truth", "kbf", "isl", "tube")} | {LABELS[n] for n in req.extras})
    return {"bands": bands, "lines": lines, "labels": labels, "state": state}


def mismatch(drawn: dict, want: dict) -> str:
    """'' when the drawn page is the run, else what differs."""
    bands = {name: offsets for name, n, *offsets in drawn["bands"] if n > 0}
    if set(bands) != set(want["bands"]):
        return f"bands drawn for {sorted(bands)}, the run has {sorted(want['bands'])}"
    for name, width in want["bands"].items():
        if any(abs(x - width) > 1e-3 * width for x in bands[name]):
            return f"{name}: drawn offsets {bands[name]}, 3 s = {width}"
    if set(drawn["lines"]) != set(want["lines"]):
        return f"lines drawn {sorted(drawn['lines'])}, the run has {sorted(want['lines'])}"
    for name, (t, y) in want["lines"].items():
        got_t, got_y = (np.asarray(a, np.float32) for a in drawn["lines"][name])
        if got_t.shape != t.shape or not (np.array_equal(got_t, t) and np.array_equal(got_y, y, equal_nan=True)):
            return f"{name}: drawn {got_y.size} points ≠ the run's {y.size} (or other values)"
    if drawn["labels"] != want["labels"]:
        return f"legend {drawn['labels']}, the run's {want['labels']}"
    return ""


def settle(page, what: str, cache: dict) -> dict:
    """Wait until the drawn trajectory plots are the run the link describes. The link follows the drawn run, so each
    round waits (on BokehJS's own state) for the bands of the link's run or a newer link, then compares everything;
    a difference is waited out until the page or its link changes, for at most 60 s in all. Returns the expectation
    met."""
    from playwright.sync_api import Error as PlaywrightError

    last, deadline = "", time.monotonic() + 60.0
    while time.monotonic() < deadline:
        url = page.url
        if url not in cache:
            cache.clear()
            cache[url] = expected(url)
        want = cache[url]
        with contextlib.suppress(PlaywrightError):
            page.wait_for_function(BANDS_OR_NEW_LINK, arg=[want["bands"], url], timeout=10_000, polling=100)
        if page.url != url:
            continue
        before = page.evaluate(f"() => JSON.stringify(({DRAWN})())")
        last = mismatch(json.loads(before), want)
        if not last:
            return want
        with contextlib.suppress(PlaywrightError):  # a page caught between two runs: wait for its next change
            page.wait_for_function(
                f"([url, before]) => window.location.href !== url || JSON.stringify(({DRAWN})()) !== before",
                arg=[url, before],
                timeout=3_000,
                polling=100,
            )
    raise AssertionError(f"{what}: the page does not show the run its link describes ({page.url}): {last}")


#: the bands drawn at the link's 3 sᵢ (``[want, url]``), or the link changed meanwhile
BANDS_OR_NEW_LINK = """([want, url]) => window.location.href !== url || Object.entries(want).every(([name, w]) =>
    Array.from(Bokeh.index.all_views()).some(v => v.model.type === 'Band' && v._upper && v.model.source.name === name
        && v.model.source.data.y.length > 0 && Math.abs(v._upper[0] - v.model.source.data.y[0] - w) <= 1e-3 * w))"""


def controls_mismatch(page, state: AppState) -> str:
    """'' when every model control shows the input of the run ``state`` (the link's) describes, else what differs."""
    held = page.evaluate(CONTROLS, CONTROL_TITLES)
    for key, value in held.items():
        want = state.get(key)
        if key == "alpha" and want == 0.0:
            continue  # α = 0: the slider (log α) is disabled and shows no value
        # a log slider holds log10 of the 3-digit value, or the key's position that value was rounded from
        ok = value == want if key in ("m", "seed") else value is not None and abs(value - math.log10(want)) <= 0.006
        if not ok:
            return f"{key}: the control holds {value}, the link {want}"
    return ""


def link_state(url: str) -> AppState:
    """The inputs the link ``url`` names (no run)."""
    state = AppState()
    state.set_inputs(parse_query(urllib.parse.urlsplit(url).query))
    return state


def wait_controls(page) -> None:
    """Wait (on BokehJS's own state, at most 20 s) until every model control shows what the page's link names, the
    link read again whenever it changes."""
    from playwright.sync_api import Error as PlaywrightError

    deadline = time.monotonic() + 20.0
    while time.monotonic() < deadline:
        url = page.url
        state = link_state(url)
        want = json.dumps({k: state.get(k) for k in CONTROL_TITLES})
        cond = f"""([titles, url]) => {{ const want = {want}; const held = ({CONTROLS})(titles);
            return window.location.href !== url || Object.entries(held).every(([k, v]) =>
                (k === 'alpha' && want[k] === 0) || (k === 'm' || k === 'seed' ? v === want[k]
                    : v !== null && Math.abs(v - Math.log10(want[k])) <= 0.006)); }}"""
        with contextlib.suppress(PlaywrightError):
            page.wait_for_function(cond, arg=[CONTROL_TITLES, url], timeout=3_000, polling=100)
        if page.url == url and not controls_mismatch(page, state):
            return


def settle_all(page, what: str, cache: dict) -> dict:
    """Wait until every control and the picture show the run the link describes (:func:`settle`); at most 90 s."""
    deadline, last = time.monotonic() + 90.0, ""
    while time.monotonic() < deadline:
        wait_controls(page)
        want = settle(page, what, cache)
        last = controls_mismatch(page, want["state"])
        if not last:
            return want
    raise AssertionError(f"{what}: a control does not show the run its link describes ({page.url}): {last}")


def refused_end(page, rng: random.Random, state: AppState) -> str:
    """A slider pushed to an end the other inputs refuse (too many steps), if one is; else a refused seed typed."""
    refused = []
    for key, end in ENDS.items():
        trial = AppState()
        trial.set_inputs({k: state.get(k) for k in CONTROL_TITLES} | {key: end})
        if plan(trial.request())[3].N > APP_MAX_STEPS:
            refused.append(key)
    if not refused:
        return typed_seed(page, rng)
    key = rng.choice(refused)
    name = SLIDERS.get(key) or declaration(key).label
    handle = page.get_by_role("slider", name=name)
    handle.focus()
    handle.press("End")
    page.locator(".isl-refusal", has_text=f"{declaration(key).label} = {ENDS[key]:g}").wait_for(timeout=30_000)
    return f"{key} End (refused)"


def typed_seed(page, rng: random.Random) -> str:
    typed = rng.choice(BAD_SEEDS)
    box = page.get_by_role("textbox", name="seed")
    box.fill(typed)
    box.press("Enter")
    page.locator(".isl-refusal", has_text="seed must be").wait_for(timeout=30_000)
    return f"seed typed {typed[:12]!r} (refused)"


def history(page, rng: random.Random) -> str:
    """Back, or Forward when there is one (and never back beyond the dashboard's first view); the page reopens at that
    link, on the tab it names (:func:`reopened_tab`)."""
    back, forward = page.evaluate(
        """() => { const i = navigation.currentEntry.index, before = navigation.entries()[i - 1];
            return [Boolean(before && before.url.startsWith(location.origin)), navigation.canGoForward]; }"""
    )
    step = "Forward" if forward and (not back or rng.random() < 0.5) else "Back" if back else ""
    if not step:
        return "no history yet"
    with page.expect_event("load", timeout=30_000):  # the page reopens at that address
        page.go_forward() if step == "Forward" else page.go_back()
    tab = link_state(page.url).tab
    if tab != "trajectories":
        return f"{step} {reopened_tab(page, tab)}"
    page.wait_for_function(PLOT_DATA, timeout=30_000)
    return step


def reopened_tab(page, tab: str) -> str:
    """A page reopened on ``tab`` (its link's) shows that tab, drawn for the link's run, and the test goes back to the
    trajectories (the property's subject). The test opens no tab but the Scenarios one."""
    assert tab == "scenarios", f"the link {page.url} names the tab {tab!r}, which no action opens"
    page.wait_for_function(TAB_OPEN, arg=SCENARIOS, timeout=30_000)
    state = link_state(page.url)
    scenario_drawn(page, state.sigma, state.nu, f"reopened at {page.url}")
    return "to the Scenarios tab (drawn), then the trajectories"


def scenario_drawn(page, sigma0: float, nu: float, what: str) -> None:
    """Wait until the open Scenarios tab's legend names the run at σ(0) = ``sigma0`` and ``nu`` (``what`` set it),
    then open the trajectories again."""
    from playwright.sync_api import Error as PlaywrightError

    want = [f"Kalman–Bucy for constant σ = σ(0) = {sigma0:g}", f"ISL (ν = {nu:.4g})"]
    try:
        page.wait_for_function(
            f"(want) => {{ const got = ({SCENARIO_LABELS})(); return want.every(w => got.includes(w)); }}",
            arg=want,
            timeout=120_000,
        )
    except PlaywrightError:
        raise AssertionError(f"{what}: legend {page.evaluate(SCENARIO_LABELS)}, the run's {want}") from None
    page.get_by_role("tab", name=TRAJECTORIES).click()
    page.wait_for_function(TAB_OPEN, arg=TRAJECTORIES, timeout=30_000)


def act(page, rng: random.Random, state: AppState) -> str:
    """One random action a class would take; returns what it did."""
    kinds = ["preset", "slider", "view", "extra", "noise", "scenario", "refused", "history"]
    kind = rng.choices(kinds, weights=[2, 10, 2, 2, 2, 0.3, 1.5, 0.8])[0]
    if kind == "refused":
        return refused_end(page, rng, state)
    if kind == "history":
        return history(page, rng)
    if kind == "preset":
        name = rng.choice(PRESET_BUTTONS)
        page.get_by_role("button", name=name, exact=True).click()
        return f"preset {name}"
    if kind == "slider":
        key = rng.choice(["alpha", "sigma", "sigma", "nu", "nu", "m"])
        # m at most 4: a larger run is computed as a job, not followed live (the live property is the one here)
        press = (
            rng.choice(["ArrowLeft", "ArrowRight"])
            if key != "m"
            else ("ArrowRight" if state.m < 4 and (state.m <= 2 or rng.random() < 0.5) else "ArrowLeft")
        )
        if key == "alpha" and state.alpha <= 0.05:
            press = "ArrowRight"  # α = 0 is paper B's model, reached by its own checkbox
        handle = page.get_by_role("slider", name=SLIDERS[key])
        handle.focus()
        handle.press(press)
        return f"{key} {press}"
    if kind == "view":
        name = "Errors (estimate − signal)" if state.view != "errors" else "Signal and estimates"
        page.get_by_role("button", name=name, exact=True).click()
        return f"view {name}"
    if kind == "extra":
        name = rng.choice(EXTRA_BOXES)
        box = page.get_by_role("checkbox", name=name, exact=True)
        if not box.is_visible():
            page.get_by_role("button", name="Other filters (σ unknown)").click()
        box.click()
        return f"toggle {name}"
    if kind == "noise":
        page.get_by_role("button", name="new noise", exact=True).click()
        return "new noise"
    return scenario_preset(page, rng)


def scenario_preset(page, rng: random.Random) -> str:
    """Open the Scenarios tab, click a preset, check its legend names the run it set, and come back."""
    label = rng.choice(list(SCENARIO_PRESETS))
    page.get_by_role("tab", name=SCENARIOS).click()
    page.wait_for_function(TAB_OPEN, arg=SCENARIOS, timeout=30_000)
    page.get_by_label("scenario preset (the table's columns)").select_option(label=label)
    inputs = SCENARIO_PRESETS[label]
    scenario_drawn(page, inputs["sigma"], inputs["nu"], f"scenario preset {label}")
    return f"scenario preset {label}"


def seeds() -> list[int]:
    """The sequences this run replays: :data:`SEEDS`, or the one ``ISL_PROPERTY_SEED`` names (``random``: a fresh
    one, shown in the test's id)."""
    chosen = os.environ.get("ISL_PROPERTY_SEED")
    if not chosen:
        return list(SEEDS)
    return [random.SystemRandom().randrange(2**32) if chosen == "random" else int(chosen)]


def diagnosis(page, log, console: list[str]) -> str:
    """What a failure report needs beyond the actions: the page's address, the documents BokehJS holds (none: no
    session reached the page), the page's console errors and the server's last warnings and errors."""
    try:
        held = page.evaluate(
            """() => [window.location.href, window.Bokeh ? Bokeh.documents.map(d => d._all_models.size) : null]"""
        )
    except Exception as exc:  # noqa: BLE001  (the page itself may be gone: say so, the report goes on)
        held = [page.url, f"not readable: {exc!r}"]
    lines = [
        line for line in log.read_text("utf-8", "replace").splitlines() if " WARNING " in line or " ERROR " in line
    ]
    return (
        f"page at {held[0]}, BokehJS documents (models each): {held[1]}; console errors: {console[-5:]}; "
        f"server warnings and errors: {lines[-8:]}"
    )


@pytest.mark.slow
@pytest.mark.parametrize("seed", seeds())
def test_after_every_random_action_the_page_draws_the_run_its_link_describes(app_server, seed):
    # fixed sequences (a failure is seen again, never by luck, as the project's Hypothesis profile); a run with
    # ISL_PROPERTY_SEED=random explores a fresh one, which the test's id names
    rng = random.Random(seed)
    actions = int(ACTIONS) if ACTIONS else SEEDS.get(seed, DEFAULT_ACTIONS)
    done: list[str] = []
    url, log = app_server
    # the scenario pictures small (2 runs, 12/rₘᵢₙ): their legends are checked, their statistics elsewhere
    with dashboard(url + "?sc_runs=2&sc_horizon=12", viewport={"width": 1280, "height": 900}) as page:
        cache: dict = {}
        errors: list[str] = []  # a script error of the page (a change it could not apply), named with its action
        console: list[str] = []
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.on("console", lambda msg: console.append(msg.text) if msg.type == "error" else None)
        try:
            want = settle(page, "the first run", cache)
            while len(done) < actions:
                done.append(act(page, rng, want["state"]))
                want = settle_all(page, f"after {done[-1]}", cache)
                assert not errors, f"the page raised {errors}"
        except Exception as exc:  # an assertion or a wait that timed out: either way, the sequence that led to it
            raise AssertionError(
                f"ISL_PROPERTY_SEED={seed}, after {len(done)} actions {done[-8:]}: {exc!r}; "
                f"{diagnosis(page, log, console)}"
            ) from exc
    assert len(done) == actions
    if seed in BACK_ONTO_SCENARIOS and not ACTIONS:  # a change of the page can move the action: the seed then says so
        assert any(a.startswith("Back to the Scenarios tab") for a in done), (
            f"ISL_PROPERTY_SEED={seed} no longer goes Back onto a link left on the Scenarios tab: {done}"
        )


def test_back_onto_a_link_left_on_the_scenarios_tab_reopens_that_tab_drawn(app_server):
    # the fewest actions that timed out in the history action: the Scenarios tab opened until the link names it, the
    # trajectories again, then Back — the page reopens on the Scenarios tab (its link's), not the trajectories
    url, _ = app_server
    with dashboard(url + "?sc_runs=2&sc_horizon=12", viewport={"width": 1280, "height": 900}) as page:
        cache: dict = {}
        settle(page, "the first run", cache)
        for title, named in ((SCENARIOS, True), (TRAJECTORIES, False)):
            page.get_by_role("tab", name=title).click()
            page.wait_for_function(TAB_OPEN, arg=title, timeout=30_000)
            page.wait_for_function(
                "(named) => (new URLSearchParams(location.search).get('tab') === 'scenarios') === named",
                arg=named,
                timeout=30_000,
            )
        assert history(page, random.Random(0)) == "Back to the Scenarios tab (drawn), then the trajectories"
        settle_all(page, "back on the trajectories", cache)
