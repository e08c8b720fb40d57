"""The served dashboard's long jobs and its frame policy in chromium: the ν-sweep's points and the worst-case table,
the high-order sweep, the Scenario tab and its who-wins map, and another site framing the page (set-up in
``_browser.py``).
"""

from __future__ import annotations

import contextlib
import re

import pytest
from _browser import NAMED, dashboard, free_port, new_page

pytestmark = [pytest.mark.browser]


SIM_POINTS = f"""() => {{
    const src = ({NAMED})('sweep-sim-1-0');
    return src !== null && src.data.y.length > 0;
}}"""


def test_simulated_sweep_points_and_the_worst_case_table_render(app_server):
    """The two on-demand simulations, clicked in the browser, draw their results and raise no error."""
    url, log = app_server
    query = "?sweep_horizon=20&sweep_sigmas=[20]&wc_alphas=[1]&wc_n_sigma=2&wc_horizon=20"  # small: seconds
    with dashboard(url + query) as page:
        page.get_by_role("tab", name="ν sweep (paper A, Fig. 2)").click()
        page.get_by_role("button", name="Simulate points").click()
        page.wait_for_function(SIM_POINTS, timeout=120_000)
        page.get_by_role("tab", name="Worst case over σ").click()
        page.get_by_role("button", name="Compute").click()
        table = page.locator("table.isl-worst")
        table.wait_for(timeout=120_000)
        rows = table.inner_text()
        body = page.locator("body").inner_text()  # (an error applying the results: a notification, and the log)
    assert "α = 1" in rows and "ISL, minimax ν" in rows and "ISL, ν from table A.31" in rows
    assert "Something went wrong" not in body
    text = log.read_text()
    assert "Traceback" not in text, text[-3000:]


@pytest.mark.slow
def test_the_high_order_sweep_measures_the_optimal_filter_at_one(app_server):
    """m = 6, α = 0, the sweep's longest horizon (2000/r_min): the Kalman–Bucy check column sits at 1 within its
    interval or ±3 % — it read 1126–2302 while estimates and truth were integrated separately (X₁ ~ t^5.5)."""
    url, log = app_server
    query = "?m=6&alpha=0&beta_from_w=false&beta=1&sweep_horizon=2000"
    with dashboard(url + query) as page:
        page.get_by_role("tab", name="ν sweep (paper A, Fig. 2)").click()
        page.get_by_role("button", name="Simulate points").click()
        check = page.get_by_text("Check — Kalman–Bucy measured ratios")
        check.wait_for(timeout=300_000)
        note = check.inner_text()
    checks = [tuple(map(float, c)) for c in re.findall(r"(\d+\.\d+) \[(\d+\.\d+), (\d+\.\d+)\]", note)]
    assert len(checks) == 3 * 6, note  # three σ, six coordinates
    assert all(lo <= 1.0 <= hi or abs(r - 1.0) <= 0.03 for r, lo, hi in checks), note
    assert "Traceback" not in log.read_text()


@contextlib.contextmanager
def lms_page(app_url: str, port: int = 0):
    """A course page on another port (another origin) that shows ``app_url`` in an iframe; yields its URL."""
    import http.server
    import threading

    html = f'<!doctype html><title>course</title><iframe id="isl" src="{app_url}" width="1200" height="800"></iframe>'

    class Page(http.server.BaseHTTPRequestHandler):
        def do_GET(self):  # http.server's name
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
    with new_page() as page:
        frame = page.frame_locator("#isl")
        drawn = frame.locator(".bk-Canvas, .bk-panel-models-layout-Column").first
        if expect == "blocked":
            with page.expect_console_message(lambda msg: "frame-ancestors" in msg.text, timeout=30_000):
                page.goto(page_url)
            return "shown" if drawn.count() else "blocked"
        page.goto(page_url)
        drawn.wait_for(timeout=30_000)
        return "shown"


@pytest.mark.slow
def test_another_site_cannot_frame_the_dashboard_unless_it_is_named(app_server, tmp_path):
    """By default the dashboard refuses to be framed by another origin (CSP frame-ancestors 'self': the shared server
    runs with the defaults); a course page named in ISL_FRAME_ANCESTORS shows it."""
    from _serving import served as serve_app

    lms_port = free_port()
    with lms_page(app_server[0], lms_port) as lms:
        assert _framed(lms, "blocked") == "blocked"
    lms_origin = f"http://127.0.0.1:{lms_port}"
    with (
        serve_app(tmp_path, "--stats-interval", "0", env={"ISL_FRAME_ANCESTORS": lms_origin}) as (url, _, _),
        lms_page(url + "/app", lms_port) as lms,
    ):
        assert _framed(lms, "shown") == "shown"


SCENARIO_DATA = f"""() => {{
    const src = ({NAMED})('scenario-ratio');
    return !!(src && src.data.t && src.data.t.length > 0 && src.data.isl_model);
}}"""


def test_the_scenario_tab_draws_a_linked_scenario_and_its_map(app_server):
    """A link with a scenario opens the Scenario tab on it: the rolling ratios of every filter are drawn, the map
    is computed on request into coloured cells, and the link keeps the scenario."""
    url, log = app_server
    with dashboard(url + "?sc_noise=student&sc_runs=4&sc_map=sensor&sc_map_seeds=2") as page:
        page.get_by_role("tab", name="Scenarios: σ(t), tails, sensor").click()
        page.wait_for_function(SCENARIO_DATA, timeout=60_000)
        note = page.get_by_text("Simulated in", exact=False).first.inner_text()
        key = page.get_by_text("pooled over the", exact=False).first.inner_text()
        page.get_by_role("button", name="Compute map").click()
        cells = page.locator("table.isl-scn td.cell")
        cells.first.wait_for(timeout=120_000)
        n_cells = cells.count()
        link = page.url
    assert "4 runs" in note and "Tuning:" in note
    assert "pooled over the 4 runs" in key and "95 % interval" in key
    assert n_cells == 6  # the sensor map's six intervals, one row
    assert "sc_noise=student" in link and "sc_runs=4" in link
    assert "Traceback" not in log.read_text()
