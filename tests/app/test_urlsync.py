"""The inputs in the URL (app.urlsync): links open the same view, bad links are refused by name, writes wait
for the run they started.

Headless: a stand-in for ``pn.state.location`` (only its ``search`` matters) and the state's own job runner.
"""

import threading
import urllib.parse
from concurrent.futures import ThreadPoolExecutor

import param
import pytest
from _loop import ManualLoop
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.jobs import Jobs
from app.state import AppState, input_label
from app.urlsync import URL_INPUTS, URL_PAUSE, UrlSync, parse_query, query_string, read_query


class Location(param.Parameterized):
    search = param.String("")


def linked(search: str = "", jobs: Jobs | None = None) -> tuple[AppState, Location]:
    state, location = AppState(jobs=jobs), Location(search=search)
    UrlSync(state, location)
    state.start()
    return state, location


def test_a_link_sets_the_inputs_it_names_and_leaves_the_rest_at_their_defaults():
    state, _ = linked('?sigma=200&m=2&nu=0.5&extra_filters=["kbf_adaptive"]&sweep_sigmas=[5,50]')
    assert (state.sigma, state.m, state.nu) == (200.0, 2, 0.5)
    assert state.baselines.extra_filters == ["kbf_adaptive"] and state.sweep.sigmas == [5.0, 50.0]
    assert state.alpha == AppState.param.alpha.default and state.horizon == AppState.param.horizon.default
    assert state.run.model.sigma == 200.0 and state.run.model.m == 2 and state.run.nu == 0.5
    assert [tr.name for tr in state.run.tracks[2:]] == ["kbf_adaptive"]
    assert state.message == ""


@pytest.mark.parametrize(
    "bad, label",
    [
        ("sigma=-3", "σ"),
        ("m=abc", "m"),
        ("m=2.5", "m"),
        ("nu=nan", "ν"),
        ("horizon=1e9", "horizon"),
        ("beta_from_w=7", "β from w"),
    ],
)
def test_a_bad_value_in_a_link_is_refused_by_name_and_the_rest_applies(bad, label):
    state, _ = linked(f"?{bad}&seed=7")
    assert state.seed == 7 and state.run.seed == 7
    assert state.message.startswith("Refused") and label in state.message
    assert state.run is not None and state.message_kind == "danger"


def test_the_url_holds_the_non_default_inputs_and_keeps_foreign_keys():
    state, location = linked("?utm=class&sigma=200")
    state.nu = 0.5
    assert location.search == "?utm=class&sigma=200&nu=0.5"
    state.sigma = AppState.param.sigma.default  # back to its default: dropped from the link
    assert location.search == "?utm=class&nu=0.5"
    assert parse_query(location.search) == {"nu": 0.5}


def test_a_refused_value_never_reaches_the_url():
    state, location = linked()
    state.set("sigma", -1.0)  # as the page's box sends it
    assert "Refused" in state.message and location.search == ""


def test_a_value_refused_only_with_the_others_never_reaches_the_url():
    """α = 100 with σ = 741 needs too many steps: the run is refused after its job, α returns to the run on screen's,
    and the link, written once the change is answered, names the run on screen (no alpha=100 at any moment)."""
    loop, pool = ManualLoop(), ThreadPoolExecutor(max_workers=1)
    try:
        state, location = linked("?sigma=741", jobs=Jobs({"run": pool, "theory": pool}, schedule=loop.schedule))
        loop.pump(lambda: not state.computing and state.run is not None)
        seen = []
        location.param.watch(lambda event: seen.append(event.new), "search")
        state.alpha = 100.0
        assert state.computing and location.search == "?sigma=741"
        loop.pump(lambda: not state.computing and "alpha" in state.refusals)
        assert state.alpha == AppState.param.alpha.default and location.search == "?sigma=741"
        assert all("alpha" not in search for search in seen), seen
        assert state.run.model.alpha == state.alpha
    finally:
        pool.shutdown(wait=True)


def test_every_input_round_trips_through_the_query():
    state, _ = linked()
    state.set_inputs(
        dict(
            alpha=2.0,
            beta_from_w=False,
            beta=7.5,
            sigma=3.0,
            nu=0.2,
            m=4,
            seed=11,
            horizon=20.0,
            sweep_sigmas=[1.0, 10.0],
            sweep_horizon=50.0,
            extra_filters=["kbf_mismatched", "isl_model"],
            sigma_design=50.0,
            sigma_min=1.0,
            sigma_max=100.0,
            wc_alphas=[0.1, 1.0],
            wc_n_sigma=4,
            wc_horizon=500.0,
            sc_runs=7,
            sc_noise="student",
            sc_map="tails",
        )
    )
    assert state.message == "" and state.baselines.extra_filters == ["kbf_mismatched", "isl_model"]
    other, _ = linked(query_string(state))
    assert other.message == ""
    assert {n: other.get(n) for n in URL_INPUTS} == {n: state.get(n) for n in URL_INPUTS}


def test_browser_navigation_applies_the_new_query():
    state, location = linked("?sigma=200")
    location.search = "?nu=0.5"  # back/forward: σ returns to its default, ν changes, in one run
    assert state.sigma == AppState.param.sigma.default and state.nu == 0.5
    assert state.run.model.sigma == state.sigma and state.run.nu == 0.5


def test_the_url_is_written_with_the_run_it_started_not_before():
    loop, pool = ManualLoop(), ThreadPoolExecutor(max_workers=1)
    try:
        state, location = linked(jobs=Jobs({"run": pool, "theory": pool}, schedule=loop.schedule))
        state.sigma = 50.0
        assert state.computing and location.search == ""  # the run is still being computed
        loop.pump(lambda: not state.computing)
        assert state.run.model.sigma == 50.0 and location.search == "?sigma=50"
        state.sweep.sigmas = [3.0, 30.0]  # starts no run: written at once
        assert location.search == "?sigma=50&sweep_sigmas=[3,30]"
    finally:
        pool.shutdown(wait=True)


def test_in_a_served_session_the_url_follows_once_the_inputs_rest_and_the_run_is_answered():
    """Served, the write waits (``defer``: here a list of what would run later, ``clock`` the test's) until the inputs
    have rested URL_PAUSE s and their run is answered, instead of riding ahead of the plots or landing in the middle
    of a drag's next update."""
    loop, pool, deferred, now = ManualLoop(), ThreadPoolExecutor(max_workers=1), [], [0.0]
    held = threading.Event()  # set at the latest when the test ends (the pool's thread waits on it)
    try:
        state, location = AppState(jobs=Jobs({"run": pool, "theory": pool}, schedule=loop.schedule)), Location()
        UrlSync(state, location, lambda fn, after: deferred.append((after, fn)), clock=lambda: now[0])
        state.start()
        loop.pump(lambda: not state.computing)

        state.sigma = 50.0  # at t = 0
        loop.pump(lambda: not state.computing)
        assert state.run.model.sigma == 50.0 and location.search == "" and len(deferred) == 1
        assert deferred[0][0] == URL_PAUSE
        now[0] = 0.2
        state.sigma = 60.0  # moved while the pause runs
        now[0] = 0.3
        deferred.pop()[1]()
        assert location.search == "" and deferred[0][0] == pytest.approx(0.2)  # waits until it has rested 0.3 s
        loop.pump(lambda: not state.computing)
        now[0] = 0.5
        deferred.pop()[1]()
        loop.q.get_nowait()()  # the write, on the session's loop
        assert location.search == "?sigma=60" and not deferred

        now[0] = 1.0
        state.sigma = 70.0
        loop.pump(lambda: not state.computing)
        # a run still in flight when the pause ends: written once it is answered. Held in flight behind a job that
        # waits for the test (the pool has one thread): a run that ended first would be answered before the pause
        pool.submit(held.wait, 60.0)
        state.seed = 3
        now[0] = 1.4
        deferred.pop()[1]()
        assert not deferred
        held.set()
        loop.pump(lambda: not state.computing and loop.q.empty())
        assert location.search == "?sigma=60" and len(deferred) == 1  # the answer armed the next pause
        now[0] = 1.8
        deferred.pop()[1]()
        loop.q.get_nowait()()
        assert location.search == "?sigma=70&seed=3"

        state.sweep.sigmas = [3.0, 30.0]  # starts no run: written once it has rested
        now[0] = 2.1
        deferred.pop()[1]()
        loop.q.get_nowait()()
        assert location.search == "?sigma=70&seed=3&sweep_sigmas=[3,30]"
    finally:
        held.set()
        pool.shutdown(wait=True)


# ------------------------------------------------------------------------------- hostile links (hypothesis)
HOSTILE_TEXT = st.one_of(
    st.text(max_size=40),
    st.sampled_from(
        [
            "NaN",
            "nan",
            "-Infinity",
            "inf",
            "1e999",
            "٣",
            "１２",
            "𝟙",
            "0x10",
            "[]",
            "[[1]]",
            "",
            " ",
            "true",
            "[5,50]",
            "kbf_adaptive",
            "\x00",
            "%00",
        ]
    ),
    st.integers(1, 3000).map(lambda d: "[" * d),
    st.integers(1, 6000).map(lambda d: "9" * d),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-(10**20), 10**20).map(str),
    st.lists(st.floats(-1e4, 1e4).map(repr), max_size=8).map(lambda xs: "[" + ",".join(xs) + "]"),
)
QUERIES = st.one_of(
    st.text(max_size=300),
    st.lists(st.tuples(st.sampled_from([*URL_INPUTS, "utm", "Sigma", ""]), HOSTILE_TEXT), max_size=6).map(
        lambda pairs: "?" + urllib.parse.urlencode(pairs)
    ),
)


@settings(max_examples=1200)
@given(search=QUERIES)
def test_any_query_is_read_without_an_exception_and_every_problem_is_named(search):
    values, problems = read_query(search)
    assert set(values) <= set(URL_INPUTS) and not set(values) & set(problems)
    for key, text in problems.items():
        assert " must be " in text and (key == "" or input_label(key, link=True) in text), text
        assert len(text) < 400


@settings(max_examples=200, suppress_health_check=[HealthCheck.too_slow])
@given(search=QUERIES)
def test_any_link_opens_a_run_or_says_why_and_leaves_a_clean_url(search):
    state, location = linked(search)
    assert state.run is not None or state.message.strip(), "a blank page"
    _, problems = read_query(search)
    if problems and "" not in problems:
        assert state.message.startswith("Refused")
        assert all(input_label(key) in state.message for key in problems)
    assert read_query(location.search)[1] == {}  # the link now spells only what the page shows
    assert "Traceback" not in state.message
