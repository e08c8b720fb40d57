"""The served dashboard in a real browser: Debian's chromium driven by Playwright.

``panel serve app/app.py`` runs in a subprocess on a free loopback port; the test moves the σ slider with
the keyboard and waits until the trajectory plot's data and the numbers table have both changed, and until
the URL carries the new σ. A screenshot goes to a temporary directory (``$ISL_ARTIFACTS`` if set) — an
artifact for CI, never committed. Others click a legend entry, tick the other filters, open links at the limits, fit
a projector, switch the error view, download, and list every request the page makes (none may leave the server). The
long jobs and the framing check are in ``test_browser_jobs.py``; the shared set-up in ``_browser.py``.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
import pytest
from _browser import NAMED, PLOT_DATA, dashboard, new_page
from playwright.sync_api import expect

pytestmark = [pytest.mark.browser]


def test_sigma_slider_updates_plot_table_and_url(app_server):
    url, log = app_server
    artifacts = Path(os.environ.get("ISL_ARTIFACTS") or log.parent)
    with dashboard(url) as page:
        before_plot = page.evaluate(PLOT_DATA)
        table = page.locator("table.isl-numbers.ratios")
        before_table = table.inner_text()
        slider = page.locator(".bk-input-group", has=page.locator(".bk-slider-title", has_text="σ:"))
        handle = slider.locator(".noUi-handle")
        for _ in range(5):
            handle.press("ArrowRight")
        page.wait_for_function(
            f"(before) => {{ const now = ({PLOT_DATA})(); return now && now !== before; }}",
            arg=before_plot,
            timeout=20_000,
        )
        expect(table).not_to_have_text(before_table, timeout=20_000)  # Playwright waits for the new numbers
        after_table = table.inner_text()
        page.wait_for_url(lambda u: "sigma=" in u, timeout=20_000)
        page.screenshot(path=str(artifacts / "dashboard_after_sigma.png"), full_page=True)
    assert after_table != before_table
    assert "X₁ position" in after_table
    text = log.read_text()
    assert "Traceback" not in text, text[-3000:]


HIDE_ISL_KEY = """() => {
    const doc = Bokeh.documents[0];
    const item = Array.from(doc.all_models).find(m => m.label && m.label.value && m.label.value.startsWith('X̌ᵢ ISL'));
    item.renderers[0].visible = false;   // what a click on the entry does (click_policy "hide")
}"""

ISL_LINES_VISIBLE = """() => {
    const doc = Bokeh.documents[0];
    return Array.from(doc.all_models)
        .filter(m => m.data_source && /^traj-\\d-isl$/.test(m.data_source.name)).map(m => m.visible);
}"""


def test_a_click_on_a_legend_entry_hides_that_trace_in_every_plot(app_server):
    url, _ = app_server
    with dashboard(url) as page:
        before = page.evaluate(ISL_LINES_VISIBLE)
        page.evaluate(HIDE_ISL_KEY)
        page.wait_for_function(f"() => ({ISL_LINES_VISIBLE})().every(v => !v)", timeout=20_000)
    assert len(before) == 3 and all(before)  # one ISL line per plot (m = 3), all shown before the click


def test_the_page_loads_nothing_from_other_hosts(app_server):
    """A classroom server may have no internet: every file the page asks for comes from the dashboard itself."""
    url, _ = app_server
    origin = url.rsplit("/", 1)[0]
    requested: list[str] = []
    with dashboard(url, on_request=requested.append) as page:
        page.wait_for_load_state("networkidle")
    local = origin.replace("http", "ws", 1)
    assert len(requested) > 5  # the page, its scripts and stylesheets, the websocket were all seen
    own = (origin, local, "blob:" + origin, "data:")  # blobs and data URLs are made in the page itself
    foreign = [u for u in requested if not u.startswith(own)]
    assert foreign == []


PLOT_BOXES = """() => Array.from(Bokeh.index.all_views())
    .filter(v => v.model.type === 'Figure' && v.model.title && /^X. — /.test(v.model.title.text))
    .map(v => { const r = v.el.getBoundingClientRect(); return [v.model.title.text, r.x, r.y, r.width, r.height]; })"""

EXTRA_DATA = f"""(names) => names.every(n => [1, 2, 3].every(i => {{
    const s = ({NAMED})(`traj-${{i}}-${{n}}`); return s && s.data.y.length > 0; }}))"""


def _pixels_near(image, color: str, tol: float = 0.12) -> int:
    """How many pixels of an RGB(A) float image lie within ``tol`` (per channel) of the hex ``color``."""
    rgb = np.array([int(color[k : k + 2], 16) / 255.0 for k in (1, 3, 5)])
    return int(np.sum(np.all(np.abs(image[..., :3] - rgb) <= tol, axis=-1)))


def test_every_ticked_filter_is_drawn_in_every_plot(app_server):
    """Tick each of the other filters: in every plot its line is visible — checked on the rendered pixels of its
    colour inside each plot's box, not only on the legend (the lines once held data but stayed invisible)."""
    from matplotlib.image import imread

    from app.extras import EXTRA_NAMES
    from app.views.style import EXTRA_COLORS

    url, log = app_server
    # at σ = 100 the filter designed for σ̄ = 20 differs from the optimal one (at σ = σ̄ it IS the optimal one)
    with dashboard(url + "?sigma=100", viewport={"width": 1600, "height": 1500}) as page:
        for name in EXTRA_NAMES:
            page.locator(f".extra-{name} input").click()
        page.wait_for_function(EXTRA_DATA, arg=list(EXTRA_NAMES), timeout=60_000)
        page.wait_for_function(f"() => ({PLOT_BOXES})().length === 3", timeout=20_000)
        boxes = page.evaluate(PLOT_BOXES)
        shot = imread(io.BytesIO(page.screenshot()))
    assert [b[0] for b in boxes] == ["X₁ — position", "X₂ — velocity", "X₃ — acceleration"]
    for title, x, y, w, h in boxes:
        plot = shot[int(y) : int(y + h), int(x) : int(x + w)]
        counts = {name: _pixels_near(plot, EXTRA_COLORS[name]) for name in EXTRA_NAMES}
        assert all(c >= 30 for c in counts.values()), (title, counts)
    assert "Traceback" not in log.read_text()


def test_a_link_over_the_step_limit_opens_on_the_nearest_allowed_setting(app_server):
    """Each value in range, together too long a run: the page shows a run at the longest horizon that fits and says
    so (it used to show empty plots, "No run yet." and sliders at values never simulated)."""
    url, log = app_server
    with dashboard(url + "?horizon=1000&sigma=0.1&nu=10000") as page:
        page.get_by_text("Showing the nearest allowed setting").wait_for(timeout=60_000)
        status = page.get_by_text("Showing the nearest allowed setting").inner_text()
        page.wait_for_function(
            "() => /horizon=/.test(location.search) && !/horizon=1000/.test(location.search)", timeout=20_000
        )  # the link now says what is shown
        boxes = page.evaluate(PLOT_BOXES)
    assert "horizon lowered from 1000 to" in status and len(boxes) == 3
    assert "Traceback" not in log.read_text()


def test_a_link_no_setting_can_serve_says_why_instead_of_empty_plots(app_server):
    url, _ = app_server
    hopeless = "?m=1&alpha=0&beta_from_w=false&beta=0.01&sigma=0.1&nu=10000&horizon=1000"
    with new_page({"width": 1600, "height": 1000}) as page:
        page.goto(url + hopeless)
        page.get_by_text("Nothing to show.").wait_for(timeout=60_000)
        text = page.locator("p", has_text="Nothing to show.").inner_text()
        boxes = page.evaluate(PLOT_BOXES)
    assert "even at the shortest horizon" in text and "lower ν or raise σ" in text
    assert [b for b in boxes if b[3] > 0 and b[4] > 0] == []  # no empty axes shown (the page's plots are hidden)


TRUTH_DATA = """() => [1, 2, 3].map(i => Array.from(
    Bokeh.documents[0].get_model_by_name(`traj-${i}-truth`).data.y).join(','))"""


def test_showing_another_filter_changes_neither_the_signal_nor_the_other_numbers(app_server):
    """The grid covers every filter a view can show, so ticking one leaves the simulated signal and the optimal and
    ISL filters' numbers bit-identical (it used to shrink h: N 1089 → 1458, X₁'s ratio 1.423 → 1.340)."""
    url, _ = app_server
    with dashboard(url) as page:
        truth = page.evaluate(TRUTH_DATA)
        table = page.locator("table.isl-numbers.ratios").inner_text()
        page.locator(".extra-kbf_adaptive input").click()
        page.wait_for_function(EXTRA_DATA, arg=["kbf_adaptive"], timeout=60_000)
        after = page.evaluate(TRUTH_DATA)
        table_after = page.locator("table.isl-numbers.ratios").inner_text()
    assert after == truth and table_after == table


def _outside(page, width: int) -> list[str]:
    """Visible buttons and inputs of the page (shadow roots included) that do not fit in ``width`` pixels."""
    out = []
    for loc in page.locator("button, input").all():
        box = loc.bounding_box() if loc.is_visible() else None
        if box is not None and box["width"] > 0 and (box["x"] < 0 or box["x"] + box["width"] > width + 0.5):
            out.append(f"{loc.evaluate('e => e.textContent || e.value || e.outerHTML.slice(0, 60)')!r} at {box}")
    return out


def test_a_projector_sized_window_shows_every_control_without_sideways_scrolling(app_server):
    """At 1280 × 720 the page does not overflow sideways, every button and input of the trajectories, ν-sweep and
    worst-case tabs lies inside the window (the worst case's Compute was cut at the edge), and the plots get the
    width: the numbers table goes below them instead of squeezing them to ≈ 310 px."""
    url, _ = app_server
    with dashboard(url, viewport={"width": 1280, "height": 720}) as page:
        for tab in (None, "ν sweep (paper A, Fig. 2)", "Worst case over σ"):
            if tab is not None:
                page.get_by_role("tab", name=tab).click()
                page.get_by_role("button", name="Simulate points" if "sweep" in tab else "Compute").wait_for()
            assert page.evaluate("document.documentElement.scrollWidth") <= 1280, tab
            assert _outside(page, 1280) == [], tab
            if tab is None:
                plot = page.locator(".bk-Canvas, canvas").first.bounding_box()
                assert plot is not None and plot["width"] >= 600, plot


def test_presenter_mode_is_one_toggle_kept_in_the_link(app_server):
    """The header's toggle reloads the page with ``present=1`` (sidebar folded away, larger text) and back, keeping
    every input of the link."""
    url, _ = app_server
    with dashboard(url + "?sigma=200") as page:

        def sidebar_width() -> float:
            return page.evaluate(
                "() => { const s = document.querySelector('#sidebar');"
                " return s ? s.getBoundingClientRect().width : -1; }"
            )

        assert sidebar_width() > 200
        page.get_by_role("button", name="Presenter mode").click()
        page.wait_for_function("() => new URL(location.href).searchParams.get('present') === '1'")
        page.wait_for_function(PLOT_DATA, timeout=30_000)
        assert "sigma=200" in page.url
        page.get_by_role("button", name="Leave presenter mode").wait_for()
        assert sidebar_width() < 50
        assert page.evaluate("parseFloat(getComputedStyle(document.body).fontSize)") >= 18
        page.get_by_role("button", name="Leave presenter mode").click()
        page.wait_for_function("() => !new URL(location.href).searchParams.has('present')")
        page.get_by_role("button", name="Presenter mode").wait_for()
        assert "sigma=200" in page.url


def test_the_error_view_switch_redraws_every_plot_without_a_server_error(app_server):
    """The switch's callback runs on a server thread; the plots must change on the session's loop (changing bokeh
    models from the thread failed with "_pending_writes should be non-None" and left the plots as they were)."""
    url, log = app_server
    with dashboard(url) as page:
        page.get_by_text("Errors (estimate − signal)", exact=True).click()
        page.wait_for_function(
            f"""() => [1, 2, 3].every(i => {{
            const s = ({NAMED})(`traj-${{i}}-truth`); return s && s.data.y.length === 2; }})""",
            timeout=20_000,
        )
        page.get_by_text("Signal and estimates", exact=True).click()
        page.wait_for_function(
            f"() => {{ const s = ({NAMED})('traj-1-truth'); return s && s.data.y.length > 2; }}", timeout=20_000
        )
    text = log.read_text("utf-8", errors="replace")
    assert "Callback failed" not in text and "_pending_writes" not in text


def test_the_downloads_carry_the_run_on_screen(app_server):
    """Both exports from the browser: the CSV with every parameter, s_i, the ratios and named columns; the PNG
    figure of the whole view."""
    url, _ = app_server
    with dashboard(url + "?sigma=200") as page:
        with page.expect_download() as csv_download:
            page.get_by_role("button", name="Download run (CSV)").click()
        text = Path(csv_download.value.path()).read_text("utf-8")
        header = [line for line in text.splitlines() if line.startswith("#")]
        assert any("sigma=200" in line and "w=3" in line for line in header), header[:3]
        assert any(line.startswith("# X1_position: s=") and " kbf " in line and " isl " in line for line in header)
        columns = header[-1]  # the named columns, then one row per kept step
        assert columns.startswith("# t,X1_position,") and columns.endswith("isl_X3_acceleration")
        assert len(text.splitlines()) > len(header) + 1000
        with page.expect_download() as png_download:
            page.get_by_role("button", name="Download figure (PNG)").click()
        png = Path(png_download.value.path()).read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000


#: in the page's BokehJS: is the skip installed, and does a stylesheet keep its text node on a rewrite with the same
#: text but take a new one with new text (app.views.paint)
SAME_STYLESHEET = """() => {
    const dom = Bokeh.require("core/dom");
    const sheet = new dom.InlineStyleSheet(":host { top: 1px; }");
    const first = sheet.el.firstChild;
    sheet.replace(":host { top: 1px; }");
    const kept = sheet.el.firstChild === first;
    sheet.replace(":host { top: 2px; }");
    return [dom.InlineStyleSheet.prototype._update.__isl_skip_same === true, kept,
            sheet.el.firstChild !== first && sheet.el.textContent.includes("2px")];
}"""


def test_a_redraw_rewrites_no_stylesheet_whose_text_stays_the_same(app_server):
    """Each paint of a plot rewrote every renderer's position stylesheet with the same text, and each rewrite made
    the browser recalculate the page's style (app.views.paint): the page installs the skip, and it still applies a
    changed text. Fails if BokehJS renames what the skip replaces."""
    url, _ = app_server
    with dashboard(url) as page:
        installed, kept, changed = page.evaluate(SAME_STYLESHEET)
    assert installed, "the page did not install app.views.paint.SKIP_SAME_STYLESHEET"
    assert kept and changed


#: σ moved as a released slider moves it; resolves with the order in which the plot's data and the page's address
#: changed (the address's change seen through history.pushState / replaceState), or what was seen after 20 s
DATA_THEN_URL = """async () => {
    const doc = Bokeh.documents[0];
    const src = doc.get_model_by_name('traj-1-isl');
    const slider = Array.from(doc.all_models).find(m => m.title === 'σ' && 'value_throttled' in m);
    const order = [];
    let done;
    const both = new Promise((resolve) => { done = resolve; });
    const see = (what) => {
        if (!order.includes(what)) order.push(what);
        if (order.length === 2) done();
    };
    for (const name of ['pushState', 'replaceState']) {
        const original = history[name].bind(history);
        history[name] = (...args) => { see('url'); return original(...args); };
    }
    src.properties.data.change.connect(() => see('data'));
    slider.value = 1.7; slider.value_throttled = 1.7;
    await Promise.race([both, new Promise((resolve) => setTimeout(resolve, 20000))]);
    return order;
}"""


def test_the_address_follows_the_new_plots_instead_of_delaying_them(app_server):
    """The URL's change rode in the plots' patch and the browser applied it first (a history update before the data
    and the redraw, app.urlsync): in the served page the plots' data comes first, the address after it."""
    url, _ = app_server
    with dashboard(url) as page:
        assert page.evaluate(DATA_THEN_URL) == ["data", "url"]
        assert "sigma=" in page.url
