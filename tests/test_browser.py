"""The served dashboard in a real browser: Debian's chromium driven by Playwright.

``panel serve app/app.py`` runs in a subprocess on a free loopback port; the test moves the σ slider with
the keyboard and waits until the trajectory plot's data and the numbers table have both changed, and until
the URL carries the new σ. A screenshot goes to a temporary directory (``$ISL_ARTIFACTS`` if set) — an
artifact for CI, never committed. Others click a legend entry, run the two on-demand simulations (ν-sweep points,
worst-case table) and list every request the page makes (none may leave the server).
"""
from __future__ import annotations

import contextlib
import io
import os
import re
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

CHROMIUM = Path("/usr/bin/chromium")
ROOT = Path(__file__).resolve().parent.parent
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]

pytestmark = [pytest.mark.browser]


def _launch(p):
    """Debian's chromium, headless: a missing browser fails the test (./scripts/test installs it), never skips it."""
    assert CHROMIUM.exists(), "Debian's chromium is not installed at /usr/bin/chromium: run ./scripts/test"
    return p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_http(url: str, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"panel serve exited with code {proc.returncode}")
        try:
            with urllib.request.urlopen(url, timeout=timeout) as r:
                if r.status == 200:
                    return
        except OSError:
            time.sleep(0.3)
    raise TimeoutError(f"{url} did not answer within {timeout:g} s")


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """URL of the dashboard served as users serve it (``python -m app.serving``: callbacks on its worker threads,
    long jobs in processes, the headers and the host check); the server's log file."""
    port = free_port()
    log = tmp_path_factory.mktemp("serve") / "panel.log"
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    cmd = [sys.executable, "-m", "app.serving", "--port", str(port), "--address", "127.0.0.1"]
    with open(log, "w") as out:
        proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=out, stderr=subprocess.STDOUT)
    try:
        wait_http(f"http://127.0.0.1:{port}/app", proc)
        yield f"http://127.0.0.1:{port}/app", log
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@contextlib.contextmanager
def dashboard(url: str, on_request=None, viewport: dict | None = None):
    """A chromium page with the dashboard at ``url`` open and its first plot drawn (``on_request(url)`` sees
    every request from the start); the test fails if the page raised a script error meanwhile."""
    from playwright import sync_api
    with sync_api.sync_playwright() as p:
        browser = _launch(p)
        try:
            page = browser.new_page(viewport=viewport or {"width": 1600, "height": 1000})
            if on_request is not None:
                page.on("request", lambda request: on_request(request.url))
            errors: list[str] = []
            page.on("pageerror", lambda error: errors.append(str(error)))
            page.goto(url)
            try:
                page.wait_for_function(PLOT_DATA, timeout=30_000)
            except sync_api.TimeoutError:
                models = page.evaluate("() => window.Bokeh ? Bokeh.documents.map(d => d._all_models.size) : null")
                raise AssertionError(f"no plot data within 30 s; page errors: {errors}; models: {models}; "
                                     f"page text: {page.inner_text('body')[:300]!r}") from None
            yield page
        finally:
            browser.close()
    # e.g. "reference p… isn't known": the browser dropped a change of the page (parts of it then stay empty)
    assert not errors, errors


#: ``named(name)``: the model of that name in the page's document, or null — also while a patch is being applied, when
#: bokeh's get_model_by_name throws on a model whose properties are not set yet ("… name is unset")
NAMED = """(name) => { try { const d = window.Bokeh && Bokeh.documents[0]; return d ? d.get_model_by_name(name) : null; }
                     catch (e) { return null; } }"""

PLOT_DATA = f"""() => {{
    const src = ({NAMED})('traj-1-isl');
    if (!src || src.data.y.length === 0) return null;
    return Array.from(src.data.y.slice(0, 50)).join(',');
}}"""


def test_sigma_slider_updates_plot_table_and_url(served):
    url, log = served
    artifacts = Path(os.environ.get("ISL_ARTIFACTS") or log.parent)
    with dashboard(url) as page:
        before_plot = page.evaluate(PLOT_DATA)
        table = page.locator("table.isl-numbers.ratios")
        before_table = table.inner_text()
        slider = page.locator(".bk-input-group", has=page.locator(".bk-slider-title", has_text="σ:"))
        handle = slider.locator(".noUi-handle")
        for _ in range(5):
            handle.press("ArrowRight")
        page.wait_for_function(f"(before) => {{ const now = ({PLOT_DATA})(); return now && now !== before; }}",
                               arg=before_plot, timeout=20_000)
        deadline = time.monotonic() + 20
        while table.inner_text() == before_table and time.monotonic() < deadline:
            page.wait_for_timeout(100)
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
    return Array.from(doc.all_models).filter(m => m.data_source && /^traj-\\d-isl$/.test(m.data_source.name)).map(m => m.visible);
}"""


def test_a_click_on_a_legend_entry_hides_that_trace_in_every_plot(served):
    url, _ = served
    with dashboard(url) as page:
        before = page.evaluate(ISL_LINES_VISIBLE)
        page.evaluate(HIDE_ISL_KEY)
        page.wait_for_function(f"() => ({ISL_LINES_VISIBLE})().every(v => !v)", timeout=20_000)
    assert len(before) == 3 and all(before)  # one ISL line per plot (m = 3), all shown before the click


def test_the_page_loads_nothing_from_other_hosts(served):
    """A classroom server may have no internet: every file the page asks for comes from the dashboard itself."""
    url, _ = served
    origin = url.rsplit("/", 1)[0]
    requested: list[str] = []
    with dashboard(url, on_request=requested.append) as page:
        page.wait_for_load_state("networkidle")
    local = origin.replace("http", "ws", 1)
    assert len(requested) > 5  # the page, its scripts and stylesheets, the websocket were all seen
    own = (origin, local, "blob:" + origin, "data:")  # blobs and data URLs are made in the page itself
    foreign = [u for u in requested if not u.startswith(own)]
    assert foreign == []


SIM_POINTS = f"""() => {{
    const src = ({NAMED})('sweep-sim-1-0');
    return src !== null && src.data.y.length > 0;
}}"""


def test_simulated_sweep_points_and_the_worst_case_table_render(served):
    """The two on-demand simulations, clicked in the browser, draw their results and raise no error."""
    url, log = served
    query = "?sweep_horizon=20&sweep_sigmas=[20]&wc_alphas=[1]&wc_n_sigma=2&wc_horizon=20"  # small: seconds
    with dashboard(url + query) as page:
        page.get_by_text("ν sweep (paper A, Fig. 2)").click()
        page.get_by_role("button", name="Simulate points").click()
        page.wait_for_function(SIM_POINTS, timeout=120_000)
        page.get_by_text("Worst case over σ").click()
        page.get_by_role("button", name="Compute").click()
        table = page.locator("table.isl-worst")
        table.wait_for(timeout=120_000)
        rows = table.inner_text()
        page.wait_for_timeout(500)  # an error raised while applying the results shows as a notification
        body = page.locator("body").inner_text()
    assert "α = 1" in rows and "ISL, minimax ν" in rows and "ISL, ν from table A.31" in rows
    assert "Something went wrong" not in body
    text = log.read_text()
    assert "Traceback" not in text, text[-3000:]


def test_the_high_order_sweep_measures_the_optimal_filter_at_one(served):
    """m = 6, α = 0, the sweep's longest horizon (2000/r_min): the Kalman–Bucy check column sits at 1 within its
    interval or ±3 % — it read 1126–2302 while estimates and truth were integrated separately (X₁ ~ t^5.5)."""
    url, log = served
    query = "?m=6&alpha=0&beta_from_w=false&beta=1&sweep_horizon=2000"
    with dashboard(url + query) as page:
        page.get_by_text("ν sweep (paper A, Fig. 2)").click()
        page.get_by_role("button", name="Simulate points").click()
        check = page.get_by_text("Check — Kalman–Bucy measured ratios")
        check.wait_for(timeout=300_000)
        note = check.inner_text()
    checks = [tuple(map(float, c)) for c in re.findall(r"(\d+\.\d+) \[(\d+\.\d+), (\d+\.\d+)\]", note)]
    assert len(checks) == 3 * 6, note  # three σ, six coordinates
    assert all(lo <= 1.0 <= hi or abs(r - 1.0) <= 0.03 for r, lo, hi in checks), note
    assert "Traceback" not in log.read_text()


PLOT_BOXES = """() => Array.from(Bokeh.index.all_views())
    .filter(v => v.model.type === 'Figure' && v.model.title && /^X. — /.test(v.model.title.text))
    .map(v => { const r = v.el.getBoundingClientRect(); return [v.model.title.text, r.x, r.y, r.width, r.height]; })"""

EXTRA_DATA = f"""(names) => names.every(n => [1, 2, 3].every(i => {{
    const s = ({NAMED})(`traj-${{i}}-${{n}}`); return s && s.data.y.length > 0; }}))"""


def _pixels_near(image, color: str, tol: float = 0.12) -> int:
    """How many pixels of an RGB(A) float image lie within ``tol`` (per channel) of the hex ``color``."""
    rgb = np.array([int(color[k:k + 2], 16) / 255.0 for k in (1, 3, 5)])
    return int(np.sum(np.all(np.abs(image[..., :3] - rgb) <= tol, axis=-1)))


def test_every_ticked_filter_is_drawn_in_every_plot(served):
    """Tick each of the other filters: in every plot its line is visible — checked on the rendered pixels of its
    colour inside each plot's box, not only on the legend (the lines once held data but stayed invisible)."""
    from matplotlib.image import imread

    from app.extras import EXTRA_NAMES
    from app.views.style import EXTRA_COLORS

    url, log = served
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
        plot = shot[int(y):int(y + h), int(x):int(x + w)]
        counts = {name: _pixels_near(plot, EXTRA_COLORS[name]) for name in EXTRA_NAMES}
        assert all(c >= 30 for c in counts.values()), (title, counts)
    assert "Traceback" not in log.read_text()


def test_a_link_over_the_step_limit_opens_on_the_nearest_allowed_setting(served):
    """Each value in range, together too long a run: the page shows a run at the longest horizon that fits and says
    so (it used to show empty plots, "No run yet." and sliders at values never simulated)."""
    url, log = served
    with dashboard(url + "?horizon=1000&sigma=0.1&nu=10000") as page:
        page.get_by_text("Showing the nearest allowed setting").wait_for(timeout=60_000)
        status = page.get_by_text("Showing the nearest allowed setting").inner_text()
        page.wait_for_function("() => /horizon=/.test(location.search) && !/horizon=1000/.test(location.search)",
                               timeout=20_000)  # the link now says what is shown
        boxes = page.evaluate(PLOT_BOXES)
    assert "horizon lowered from 1000 to" in status and len(boxes) == 3
    assert "Traceback" not in log.read_text()


def test_a_link_no_setting_can_serve_says_why_instead_of_empty_plots(served):
    url, _ = served
    hopeless = "?m=1&alpha=0&beta_from_w=false&beta=0.01&sigma=0.1&nu=10000&horizon=1000"
    from playwright import sync_api
    with sync_api.sync_playwright() as p:
        browser = _launch(p)
        try:
            page = browser.new_page(viewport={"width": 1600, "height": 1000})
            page.goto(url + hopeless)
            page.get_by_text("Nothing to show.").wait_for(timeout=60_000)
            text = page.locator("p", has_text="Nothing to show.").inner_text()
            boxes = page.evaluate(PLOT_BOXES)
        finally:
            browser.close()
    assert "even at the shortest horizon" in text and "lower ν or raise σ" in text
    assert boxes == []  # no empty axes


TRUTH_DATA = """() => [1, 2, 3].map(i => Array.from(
    Bokeh.documents[0].get_model_by_name(`traj-${i}-truth`).data.y).join(','))"""


def test_showing_another_filter_changes_neither_the_signal_nor_the_other_numbers(served):
    """The grid covers every filter a view can show, so ticking one leaves the simulated signal and the optimal and
    ISL filters' numbers bit-identical (it used to shrink h: N 1089 → 1458, X₁'s ratio 1.423 → 1.340)."""
    url, _ = served
    with dashboard(url) as page:
        truth = page.evaluate(TRUTH_DATA)
        table = page.locator("table.isl-numbers.ratios").inner_text()
        page.locator(".extra-kbf_adaptive input").click()
        page.wait_for_function(EXTRA_DATA, arg=["kbf_adaptive"], timeout=60_000)
        after = page.evaluate(TRUTH_DATA)
        table_after = page.locator("table.isl-numbers.ratios").inner_text()
    assert after == truth and table_after == table


@contextlib.contextmanager
def lms_page(app_url: str, port: int = 0):
    """A course page on another port (another origin) that shows ``app_url`` in an iframe; yields its URL."""
    import http.server
    import threading

    html = f'<!doctype html><title>course</title><iframe id="isl" src="{app_url}" width="1200" height="800"></iframe>'

    class Page(http.server.BaseHTTPRequestHandler):
        def do_GET(self):  # noqa: N802  (http.server's name)
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.end_headers()
            self.wfile.write(html.encode())

        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", port), Page)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        yield f"http://127.0.0.1:{server.server_port}/"
    finally:
        server.shutdown()
        server.server_close()


def _framed(page_url: str, expect: str) -> str:
    """Open ``page_url`` in chromium; 'blocked' if its iframe was refused, 'shown' once the dashboard draws in it.

    Waits for the event that ``expect`` announces: chromium's console report of the refused frame ('blocked') or the
    dashboard's first drawing inside the frame ('shown'); a page that gives neither fails on the timeout."""
    from playwright import sync_api
    with sync_api.sync_playwright() as p:
        browser = _launch(p)
        try:
            page = browser.new_page()
            frame = page.frame_locator("#isl")
            drawn = frame.locator(".bk-Canvas, .bk-panel-models-layout-Column").first
            if expect == "blocked":
                with page.expect_console_message(lambda msg: "frame-ancestors" in msg.text, timeout=30_000):
                    page.goto(page_url)
                return "shown" if drawn.count() else "blocked"
            page.goto(page_url)
            drawn.wait_for(timeout=30_000)
            return "shown"
        finally:
            browser.close()


def test_another_site_cannot_frame_the_dashboard_unless_it_is_named(tmp_path):
    """By default the dashboard refuses to be framed by another origin (CSP frame-ancestors 'self'); a course page
    named in ISL_FRAME_ANCESTORS shows it."""
    from _serving import served as serve_app

    lms_port = free_port()
    with serve_app(tmp_path, "--stats-interval", "0") as (url, _, _):
        with lms_page(url + "/app", lms_port) as lms:
            assert _framed(lms, "blocked") == "blocked"
    lms_origin = f"http://127.0.0.1:{lms_port}"
    with serve_app(tmp_path, "--stats-interval", "0", env={"ISL_FRAME_ANCESTORS": lms_origin}) as (url, _, _):
        with lms_page(url + "/app", lms_port) as lms:
            assert _framed(lms, "shown") == "shown"


@pytest.mark.parametrize(("lo", "hi", "expected"), [
    (0.9, 12.0, [1, 1.2, 1.5, 2, 3, 5, 10, 12]),          # a ν-sweep row: the minimum ≈ 1.1 can be read off
    (1.0, 1.3, [1, 1.05, 1.1, 1.2, 1.3]),                  # worst cases of 1.06 and 1.23 apart
    (1.0, 1e6, [1, 10, 100, 1000, 1e4, 1e5, 1e6]),          # many decades: powers of ten
    (0.5, 0.5, []),                                        # an empty range: no ticks rather than an error
])
def test_ratio_axes_tick_the_first_digits(lo, hi, expected):
    """The log ratio axes of the ν sweep and the worst case (app.views.style.ratio_ticker) tick 1, 1.2, 1.5, 2, …:
    the ticker's own JavaScript, run in chromium on the ranges those charts show."""
    from app.views.style import ratio_ticker

    ticker = ratio_ticker()
    from playwright import sync_api
    with sync_api.sync_playwright() as p:
        browser = _launch(p)
        try:
            page = browser.new_page()
            ticks = page.evaluate(
                "([code, args, cb_data]) => new Function('cb_data', ...Object.keys(args), code)"
                "(cb_data, ...Object.values(args))",
                [ticker.major_code, ticker.args, {"start": lo, "end": hi}])
        finally:
            browser.close()
    assert ticks == pytest.approx(expected)


def _outside(page, width: int) -> list[str]:
    """Visible buttons and inputs of the page (shadow roots included) that do not fit in ``width`` pixels."""
    out = []
    for loc in page.locator("button, input").all():
        box = loc.bounding_box() if loc.is_visible() else None
        if box is not None and box["width"] > 0 and (box["x"] < 0 or box["x"] + box["width"] > width + 0.5):
            out.append(f"{loc.evaluate('e => e.textContent || e.value || e.outerHTML.slice(0, 60)')!r} at {box}")
    return out


def test_a_projector_sized_window_shows_every_control_without_sideways_scrolling(served):
    """At 1280 × 720 the page does not overflow sideways, every button and input of the trajectories, ν-sweep and
    worst-case tabs lies inside the window (the worst case's Compute was cut at the edge), and the plots get the
    width: the numbers table goes below them instead of squeezing them to ≈ 310 px."""
    url, _ = served
    with dashboard(url, viewport={"width": 1280, "height": 720}) as page:
        for tab in (None, "ν sweep (paper A, Fig. 2)", "Worst case over σ"):
            if tab is not None:
                page.get_by_text(tab).click()
                page.get_by_role("button", name="Simulate points" if "sweep" in tab else "Compute").wait_for()
            assert page.evaluate("document.documentElement.scrollWidth") <= 1280, tab
            assert _outside(page, 1280) == [], tab
            if tab is None:
                plot = page.locator(".bk-Canvas, canvas").first.bounding_box()
                assert plot is not None and plot["width"] >= 600, plot


def test_presenter_mode_is_one_toggle_kept_in_the_link(served):
    """The header's toggle reloads the page with ``present=1`` (sidebar folded away, larger text) and back, keeping
    every input of the link."""
    url, _ = served
    with dashboard(url + "?sigma=200") as page:
        def sidebar_width() -> float:
            return page.evaluate("() => { const s = document.querySelector('#sidebar');"
                                 " return s ? s.getBoundingClientRect().width : -1; }")
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


def test_the_error_view_switch_redraws_every_plot_without_a_server_error(served):
    """The switch's callback runs on a server thread; the plots must change on the session's loop (changing bokeh
    models from the thread failed with "_pending_writes should be non-None" and left the plots as they were)."""
    url, log = served
    with dashboard(url) as page:
        page.get_by_text("Errors (estimate − signal)", exact=True).click()
        page.wait_for_function(f"""() => [1, 2, 3].every(i => {{
            const s = ({NAMED})(`traj-${{i}}-truth`); return s && s.data.y.length === 2; }})""",
                               timeout=20_000)
        page.get_by_text("Signal and estimates", exact=True).click()
        page.wait_for_function(f"() => {{ const s = ({NAMED})('traj-1-truth'); return s && s.data.y.length > 2; }}",
                               timeout=20_000)
    text = log.read_text("utf-8", errors="replace")
    assert "Callback failed" not in text and "_pending_writes" not in text


def test_the_downloads_carry_the_run_on_screen(served):
    """Both exports from the browser: the CSV with every parameter, s_i, the ratios and named columns; the PNG
    figure of the whole view."""
    url, _ = served
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


SCENARIO_DATA = f"""() => {{
    const src = ({NAMED})('scenario-ratio');
    return !!(src && src.data.t && src.data.t.length > 0 && src.data.isl_model);
}}"""


def test_the_scenario_tab_draws_a_linked_scenario_and_its_map(served):
    """A link with a scenario opens the Scenario tab on it: the rolling ratios of every filter are drawn, the map
    is computed on request into coloured cells, and the link keeps the scenario."""
    url, log = served
    with dashboard(url + "?sc_noise=student&sc_runs=4&sc_map=sensor&sc_map_seeds=2") as page:
        page.get_by_text("Scenarios: σ(t), tails, sensor").click()
        page.wait_for_function(SCENARIO_DATA, timeout=60_000)
        note = page.get_by_text("Simulated in", exact=False).first.inner_text()
        page.get_by_role("button", name="Compute map").click()
        cells = page.locator("table.isl-scn td.cell")
        cells.first.wait_for(timeout=120_000)
        n_cells = cells.count()
        link = page.url
    assert "4 runs" in note and "95 % interval over the runs" in note
    assert n_cells == 6  # the sensor map's six intervals, one row
    assert "sc_noise=student" in link and "sc_runs=4" in link
    assert "Traceback" not in log.read_text()
