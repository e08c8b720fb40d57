"""Slider change → plot updated in the browser: latency of the served dashboard in headless chromium.

Serves ``app/app.py`` on a free loopback port, opens it in Debian's chromium (Playwright), and changes σ
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

The machine's load average is printed: the figures are only comparable on an idle machine.
"""
from __future__ import annotations

import argparse
import os
import re
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
from playwright.sync_api import sync_playwright

ROOT = Path(__file__).resolve().parent.parent
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

#: one change: [latency, data-arrived time, messages, bytes] — all counted until the page has been quiet 150 ms
CHANGE = """async (v) => {
    const doc = Bokeh.documents[0];
    const src = doc.get_model_by_name('traj-1-isl');
    const slider = Array.from(doc.all_models).find(m => m.title === 'σ' && 'value_throttled' in m);
    window.__isl_received = [];
    const t0 = performance.now();
    const redrawn = await new Promise((resolve) => {
        const done = () => {
            src.properties.data.change.disconnect(done);
            const arrived = performance.now();
            requestAnimationFrame(() => resolve([performance.now() - t0, arrived - t0]));
        };
        src.properties.data.change.connect(done);
        slider.value = v;
        slider.value_throttled = v;
    });
    const last = () => { const r = window.__isl_received; return r.length ? r[r.length - 1][0] : t0; };
    while (performance.now() - Math.max(last(), t0 + redrawn[0]) < 150) {
        await new Promise((r) => setTimeout(r, 25));
    }
    const got = window.__isl_received;
    return [...redrawn, got.length, got.reduce((n, m) => n + m[1], 0)];
}"""

READY = """() => { const d = window.Bokeh && Bokeh.documents[0];
                   const s = d && d.get_model_by_name('traj-1-isl'); return !!(s && s.data.y.length); }"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def serve() -> tuple[subprocess.Popen, int]:
    port = free_port()
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "panel", "serve", "app/app.py", "--port", str(port), "--address", "127.0.0.1",
           "--allow-websocket-origin", f"127.0.0.1:{port}"]
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/app", timeout=120):
                return proc, port
        except OSError:
            time.sleep(0.3)
    proc.kill()
    raise TimeoutError("the dashboard did not start")


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


def report(name: str, r: dict) -> None:
    lat, arrived, comp, b = r["latency"], r["arrived"], r["compute"], r["bytes"]
    pct = lambda x: f"p50 {np.percentile(x, 50):6.1f} ms   p95 {np.percentile(x, 95):6.1f} ms"
    print(f"{name}: {len(lat)} changes")
    print(f"  slider → plot redrawn (browser): {pct(lat)}   max {lat.max():6.1f} ms")
    print(f"    until the plot's data arrived: {pct(arrived)}   (server work + transfer)")
    print(f"    from there to the redraw:      {pct(lat - arrived)}   (browser work)")
    print(f"  server compute per run:          {pct(comp)}")
    print(f"  websocket received per update:   median {np.median(b) / 1024:7.1f} kB   max {b.max() / 1024:7.1f} kB"
          f"   ({np.median(r['messages']):.0f} messages)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--changes", type=int, default=25)
    ap.add_argument("--query", action="append", help="URL query of a scenario (repeatable)")
    args = ap.parse_args()
    queries = args.query or ["", "horizon=1000"]
    print(f"load average before: {os.getloadavg()[0]:.2f} (2 cores)")
    proc, port = serve()
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            try:
                for q in queries:
                    report(f"scenario ?{q or '(Fig. 3 defaults: m = 3, α = 0.5, β = ν = 3, σ ≈ 20, 10/r_min)'}",
                           scenario(browser, port, q, args.changes))
            finally:
                browser.close()
    finally:
        proc.terminate()
        proc.wait(timeout=10)
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
