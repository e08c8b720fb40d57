"""Every control tells the truth in a real browser: a refused value never stays on a control or in the link, Back and
Forward restore the view their link names, and the number boxes read what is typed as a number.

Each test reads what BokehJS holds (the widgets' models, the box's text, the page's URL), not the server's copies.
"""

from __future__ import annotations

import math
import urllib.parse

import pytest
from _browser import NAMED, PLOT_DATA, dashboard
from playwright.sync_api import expect

from app.state import declaration

pytestmark = [pytest.mark.browser]

#: ``value(title)``: the value BokehJS holds for the widget titled so (a slider's is log10 of the input's)
VALUE = """(title) => { if (!window.Bokeh || !Bokeh.documents.length) return null;
    const m = Array.from(Bokeh.documents[0].all_models)
        .find(m => (m.type === 'Slider' || m.type === 'Spinner') && m.title === title); return m ? m.value : null; }"""
ALPHA_SLIDER = "α, damping of the top derivative"
M_SLIDER = "m, state dimension"


def query(page) -> dict[str, str]:
    return dict(urllib.parse.parse_qsl(urllib.parse.urlsplit(page.url).query))


def test_a_slider_value_refused_with_the_others_returns_to_the_run_on_screen(app_server):
    """σ = 741 and α at its end, 100: the run would need ~3 million steps; the slider comes back to α = 0.5, the link
    never says alpha=100, and the refusal beside α names α."""
    url, _ = app_server
    with dashboard(url + "?sigma=741") as page:
        page.evaluate(RECORD_URLS)
        handle = page.get_by_role("slider", name=ALPHA_SLIDER)
        handle.focus()
        handle.press("End")
        refusal = page.locator(".isl-refusal", has_text="α = 100")
        refusal.wait_for(timeout=30_000)
        page.wait_for_function(f"() => Math.abs(({VALUE})('α') - Math.log10(0.5)) < 1e-9", timeout=10_000)
        assert "is back at 0.5" in refusal.inner_text()
        sigma = page.get_by_role("slider", name="σ, observation noise intensity")
        sigma.focus()
        sigma.press("ArrowLeft")  # a good change: the link follows it, once every earlier change is answered
        page.wait_for_url(lambda u: "sigma=" in u and "sigma=741" not in u, timeout=30_000)
        urls = page.evaluate("() => window.__urls")
        assert urls and all("alpha" not in u for u in urls), urls


#: every URL the page writes to its history, kept in ``window.__urls``
RECORD_URLS = """() => { window.__urls = []; const push = window.history.pushState;
    window.history.pushState = function (state, title, url) { window.__urls.push(String(url));
                                                               return push.call(this, state, title, url); }; }"""


def history(page, step: str) -> None:
    """Back or Forward, and wait until the page at that address has drawn its run."""
    with page.expect_event("load", timeout=30_000):
        getattr(page, step)()
    page.wait_for_function(PLOT_DATA, timeout=30_000)


def test_back_and_forward_restore_the_view_their_link_names(app_server):
    url, _ = app_server
    with dashboard(url) as page:
        page.get_by_role("button", name="Fig. 3, σ = 200", exact=True).click()
        page.wait_for_url(lambda u: "sigma=200" in u, timeout=30_000)
        handle = page.get_by_role("slider", name=M_SLIDER)
        handle.focus()
        handle.press("End")
        page.wait_for_url(lambda u: "m=6" in u, timeout=30_000)
        history(page, "go_back")
        assert query(page).get("m") is None and query(page).get("sigma") == "200"
        page.wait_for_function(f"() => ({VALUE})('m (state dimension)') === 3", timeout=30_000)
        assert page.evaluate(f"() => ({NAMED})('traj-3-isl') !== null && ({NAMED})('traj-4-isl') === null")
        history(page, "go_forward")
        assert query(page).get("m") == "6"
        page.wait_for_function(f"() => ({VALUE})('m (state dimension)') === 6", timeout=30_000)
        history(page, "go_back")
        history(page, "go_back")
        page.wait_for_function(f"() => ({VALUE})('σ') === {math.log10(20.0)}", timeout=30_000)
        assert "sigma" not in query(page)


FIVE_THOUSAND_DIGITS = "9" * 5000


#: typed in the seed box one after another on one page, and what each refusal must say: no two in a row say the same,
#: so each wait sees its own refusal and not the one before
REFUSED_SEEDS = [
    ("-5", "-5 is below that range"),
    ("1e400", "too long for a float"),
    ("1.5", "1.5 is not a whole number"),
    (FIVE_THOUSAND_DIGITS, "too long for a float"),
]


def test_each_refused_typed_seed_reverts_and_is_named_for_what_was_typed(app_server):
    url, _ = app_server
    with dashboard(url) as page:
        box = page.get_by_role("textbox", name="seed")
        refusal = page.locator(".isl-refusal", has_text="seed must be a whole number")
        for typed, said in REFUSED_SEEDS:
            box.fill(typed)
            box.press("Enter")
            expect(refusal).to_have_count(1, timeout=20_000)  # beside the box, once: it replaces the one before
            expect(refusal).to_contain_text(said, timeout=20_000)
            text = refusal.inner_text()
            assert "inf is not" not in text and "1400" not in text, (typed[:12], text)
            expect(box).to_have_value("1", timeout=10_000)
            assert page.evaluate(VALUE, "seed") == 1, typed[:12]
            assert "seed" not in query(page), typed[:12]


def test_the_seed_box_steps_by_one(app_server):
    url, _ = app_server
    with dashboard(url) as page:
        before = page.evaluate(PLOT_DATA)
        box = page.get_by_role("textbox", name="seed")
        box.focus()
        box.press("ArrowUp")
        expect(box).to_have_value("2", timeout=10_000)
        page.wait_for_url(lambda u: "seed=2" in u, timeout=30_000)
        page.wait_for_function(f"(b) => ({PLOT_DATA})() !== b", arg=before, timeout=30_000)
        assert page.locator(".isl-refusal").count() == 0 or not page.locator(".isl-refusal").first.is_visible()


def test_a_whole_number_box_takes_whole_numbers_only(app_server):
    """The scenario's number of runs: "1e400" is refused as too long, not read as 1400."""
    url, _ = app_server
    with dashboard(url + "?tab=scenarios", ready="() => true") as page:
        label = declaration("sc_runs").label
        box = page.get_by_role("textbox", name=label)
        box.wait_for(timeout=60_000)
        before = box.input_value()
        box.fill("1e400")
        box.press("Enter")
        refusal = page.locator(".isl-refusal", has_text="too long for a float")
        refusal.wait_for(timeout=20_000)
        expect(box).to_have_value(before, timeout=10_000)
        assert "sc_runs" not in query(page)


@pytest.mark.parametrize(
    ("tab", "label", "typed", "said"),
    [
        ("trajectories", declaration("sigma_design").label, "-5", "-5 is below that range"),
        ("sweep", "σ values (comma separated)", "2, 1e400", "too long for a float"),
        ("worstcase", "α values (comma separated)", "1, NaN", "nan is not a finite number"),
        ("compare", "σ of the second run", FIVE_THOUSAND_DIGITS, "too long for a float"),
    ],
    ids=["sigma-design", "sweep-sigmas", "worstcase-alphas", "compare-sigma"],
)
def test_every_box_shows_its_value_again_after_a_refusal(app_server, tab, label, typed, said):
    url, _ = app_server
    with dashboard(f"{url}?tab={tab}", ready="() => true") as page:
        box = page.get_by_role("textbox", name=label)
        box.wait_for(timeout=60_000)
        before = box.input_value()
        box.fill(typed)
        box.press("Enter")
        page.locator(".isl-refusal", has_text=said).wait_for(timeout=20_000)
        expect(box).to_have_value(before, timeout=10_000)
