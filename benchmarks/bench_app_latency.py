"""Slider change → plot updated in the browser: latency of the served dashboard in headless chromium.

Serves the dashboard as users do (``python -m app.serving``) on a free loopback port, opens it in Debian's chromium
(Playwright), and changes σ
``--changes`` times (default 25, after 3 warm-up changes) by setting the σ slider's model value in the page,
exactly as a drag released there does (``value`` and ``value_throttled``). Each change is timed in the page, from
the assignment to the first animation frame after the trajectory plot's data has changed (so the browser's
redraw is included). Printed per scenario:

* p50 / p95 / max of that latency (ms), and its two parts: until the plot's data has arrived (the server's work
  and the transfer) and from there to the redraw (the browser's work);
* the server's compute time per run (simulate + decimation + theory), read from the numbers table;
* bytes and websocket messages received per update (counted in the page, by a wrapper around ``WebSocket``;
  listening from Playwright instead adds a DevTools event per frame to the browser's work).

Scenarios: paper A's Fig. 3 defaults (``?``; the target is p95 ≤ 150 ms) and the same with a 100× longer
horizon (``?horizon=1000``: ≈ 10⁵ steps, min/max-decimated to ≤ 2400 points a trace before sending).

    PYTHONPATH=. python benchmarks/bench_app_latency.py [--changes 25] [--query "horizon=1000"]
    PYTHONPATH=. python benchmarks/bench_app_latency.py --before ../isl-before   # a worktree of an older commit

With ``--before CHECKOUT`` the same scenarios run first against a server started from that checkout, then against
this one, in one run and one browser: each figure is printed for both.

The machine's load average is printed: the figures are only comparable on an idle machine.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
from pathlib import Path

import numpy as np
from playwright.sync_api import sync_playwright

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
import session_client as sc  # noqa: E402  (the scripts folder is not a package)

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]

#: counts what the page receives on its websockets: (time, bytes) per message
COUNT_MESSAGES = """
window.__isl_received = [];
const NativeWebSocket = window.WebSocket;
window.WebSocket = function (...args) {
    const ws = new NativeWebSocket(...args);
    ws.addEventListener('message', (e) => window.__isl_received.push(
        [performance.now(), typeof e.data === 'string' ? e.data.length : e.data.byteLength]));
    return ws;
};
window.WebSocket.prototype = NativeWebSocket.prototype;
Object.assign(window.WebSocket, NativeWebSocket);
"""

#: one change: [latency, data-arrived time, messages, bytes] — all counted until the page has been quiet 150 ms (and
#: at most 13 s after the change); a change whose data has not arrived within 10 s counts as missed (NaN) instead of
#: stalling the run
CHANGE = """async (v) => {
    const doc = Bokeh.documents[0];
    const src = doc.get_model_by_name('traj-1-isl');
    const slider = Array.from(doc.all_models).find(m => m.title === 'σ' && 'value_throttled' in m);
    window.__isl_received = [];
    const t0 = performance.now();
    const redrawn = await new Promise((resolve) => {
        const missed = setTimeout(() => { src.properties.data.change.disconnect(done); resolve([NaN, NaN]); }, 10000);
        const done = () => {
            clearTimeout(missed);
            src.properties.data.change.disconnect(done);
            const arrived = performance.now();
            requestAnimationFrame(() => resolve([performance.now() - t0, arrived - t0]));
        };
        src.properties.data.change.connect(done);
        slider.value = v;
        slider.value_throttled = v;
    });
    const last = () => { const r = window.__isl_received; return r.length ? r[r.length - 1][0] : t0; };
    const quiet = () => performance.now() - Math.max(last(), t0 + (redrawn[0] || 0));
    while (quiet() < 150 && performance.now() - t0 < 13000) {
        await new Promise((r) => setTimeout(r, 25));
    }
    const got = window.__isl_received;
    return [...redrawn, got.length, got.reduce((n, m) => n + m[1], 0)];
}"""

READY = """() => { const d = window.Bokeh && Bokeh.documents[0];
                   const s = d && d.get_model_by_name('traj-1-isl'); return !!(s && s.data.y.length); }"""


def serve(repo: Path):
    """``python -m app.serving`` of checkout ``repo`` on a free loopback port, once it answers ``/liveness``."""
    port = sc.free_port()
    proc = sc.start_server(port, Path(tempfile.gettempdir()) / f"isl-latency-{port}.log", repo=repo)
    try:
        sc.wait_healthy(port, 180, proc)
    except BaseException:
        sc.stop_server(proc)
        raise
    return proc, port


def compute_ms(page) -> float:
    text = page.locator("table.isl-numbers.run").inner_text()
    return float(re.search(r"compute time \(server\)\s+(\d+) ms", text).group(1))


def scenario(browser, port: int, query: str, changes: int, warmup: int = 3) -> dict:
    page = browser.new_page(viewport={"width": 1600, "height": 1000})
    page.add_init_script(COUNT_MESSAGES)
    page.goto(f"http://127.0.0.1:{port}/app?{query}")
    page.wait_for_function(READY, timeout=60_000)
    page.wait_for_timeout(1000)  # let the initial document settle
    rows, comp = [], []
    logs = np.log10(20.0) + 0.01 * np.arange(1, warmup + changes + 1)  # σ steps of one slider notch
    for k, v in enumerate(logs):
        row = page.evaluate(CHANGE, float(v))
        if k >= warmup:
            rows.append(row)
            comp.append(compute_ms(page))
    page.close()
    a = np.array(rows)
    return {"latency": a[:, 0], "arrived": a[:, 1], "messages": a[:, 2], "bytes": a[:, 3], "compute": np.array(comp)}


def report(name: str, results: dict[str, dict]) -> None:
    """The figures of one scenario, one column per server (``before`` / ``after``, or this checkout only)."""
    pct = lambda x, q: f"{np.nanpercentile(x, q):6.1f}"  # noqa: E731
    lines = [
        ("slider → plot redrawn (browser), p50 ms", lambda r: pct(r["latency"], 50)),
        ("                                 p95 ms", lambda r: pct(r["latency"], 95)),
        ("                                 max ms", lambda r: f"{np.nanmax(r['latency']):6.1f}"),
        ("missed (no new data within 10 s)", lambda r: f"{np.isnan(r['latency']).sum():6d}"),
        ("until the plot's data arrived, p50 ms", lambda r: pct(r["arrived"], 50)),
        ("  (server work + transfer)     p95 ms", lambda r: pct(r["arrived"], 95)),
        ("from there to the redraw,      p50 ms", lambda r: pct(r["latency"] - r["arrived"], 50)),
        ("  (browser work)               p95 ms", lambda r: pct(r["latency"] - r["arrived"], 95)),
        ("server compute per run,        p50 ms", lambda r: pct(r["compute"], 50)),
        ("received per update, median kB", lambda r: f"{np.median(r['bytes']) / 1024:6.1f}"),
        ("websocket messages per update", lambda r: f"{np.median(r['messages']):6.0f}"),
    ]
    first = next(iter(results.values()))
    print(f"{name}: {len(first['latency'])} changes")
    print(f"  {'':40s}" + "".join(f"{col:>10s}" for col in results))
    for label, cell in lines:
        print(f"  {label:40s}" + "".join(f"{cell(r):>10s}" for r in results.values()))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--changes", type=int, default=25)
    ap.add_argument("--query", action="append", help="URL query of a scenario (repeatable)")
    ap.add_argument(
        "--before",
        type=Path,
        metavar="CHECKOUT",
        help="first measure a server started from this other checkout (e.g. a git worktree of an "
        "older commit), then this one's",
    )
    args = ap.parse_args()
    queries = args.query or ["", "horizon=1000"]
    servers = ({"before": args.before.resolve()} if args.before else {}) | {"after" if args.before else "this": ROOT}
    print(f"load average before: {os.getloadavg()[0]:.2f} (2 cores)")
    results: dict[str, dict[str, dict]] = {q: {} for q in queries}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        try:
            for column, repo in servers.items():
                proc, port = serve(repo)
                try:
                    for q in queries:
                        results[q][column] = scenario(browser, port, q, args.changes)
                        print(f"  measured: {column}, ?{q}", flush=True)
                finally:
                    sc.stop_server(proc)
        finally:
            browser.close()
    for q in queries:
        report(f"scenario ?{q or '(Fig. 3 defaults: m = 3, α = 0.5, β = ν = 3, σ ≈ 20, 10/r_min)'}", results[q])
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
