"""The browser's work per σ change with and without the page's skip of same-text stylesheet rewrites
(``app.views.paint.SKIP_SAME_STYLESHEET``), interleaved in one page of one served dashboard.

Between rounds of slider changes (set in the page as a released drag does, as ``bench_app_latency.py`` does) the
page's ``InlineStyleSheet._update`` is switched between the installed skip and BokehJS's own body
(``this.el.textContent = css``); ``UNTHEMED_CANVAS`` stays installed in both. Printed for each: chromium's style
recalculations and their time, script time and layouts per change (DevTools ``Performance.getMetrics``), the browser's
part of a change (data arrived → next frame) and the whole latency.

    PYTHONPATH=. python benchmarks/bench_paint_skip.py [--rounds 6]

The machine's load average is printed: the figures are only comparable on an idle machine (the interleaving makes
the two columns comparable with each other).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

import numpy as np
from playwright.sync_api import sync_playwright

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "benchmarks"))
import session_client as sc  # noqa: E402  (the scripts folder is not a package)
from bench_app_latency import ARGS, CHANGE, CHROMIUM, READY  # noqa: E402

#: the skip (``on``) or BokehJS's own body; true if the skip is what is installed now
TOGGLE = """(on) => { const proto = Bokeh.require("core/dom").InlineStyleSheet.prototype;
  if (!window.__isl_skip) window.__isl_skip = proto._update;
  proto._update = on ? window.__isl_skip : function (css) { this.el.textContent = css; };
  return proto._update.__isl_skip_same === true; }"""
METRICS = ("RecalcStyleCount", "RecalcStyleDuration", "ScriptDuration", "LayoutCount")


def measure(rounds: int, per_round: int = 6) -> dict[bool, np.ndarray]:
    port = sc.free_port()
    proc = sc.start_server(port, Path(tempfile.gettempdir()) / f"isl-paint-{port}.log")
    rows: dict[bool, list] = {True: [], False: []}
    try:
        sc.wait_healthy(port, 300, proc)
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            page = browser.new_page(viewport={"width": 1600, "height": 1000})
            cdp = page.context.new_cdp_session(page)
            cdp.send("Performance.enable")
            page.goto(f"http://127.0.0.1:{port}/app")
            page.wait_for_function(READY, timeout=120_000)
            page.wait_for_timeout(1000)  # let the initial document settle

            def metrics() -> dict[str, float]:
                return {m["name"]: m["value"] for m in cdp.send("Performance.getMetrics")["metrics"]}

            v = np.log10(20.0)
            for r in range(rounds):
                for on in (True, False) if r % 2 == 0 else (False, True):
                    assert page.evaluate(TOGGLE, on) == on
                    for k in range(per_round):
                        v += 0.01 if (k + r) % 2 == 0 else -0.01  # one slider notch up or down
                        before = metrics()
                        latency, arrived, *_ = page.evaluate(CHANGE, float(v))
                        after = metrics()
                        if k >= 1:  # the first change of a round pays for the switch
                            rows[on].append([after[n] - before[n] for n in METRICS] + [latency - arrived, latency])
            browser.close()
    finally:
        sc.stop_server(proc)
    return {on: np.array(r) for on, r in rows.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=6)
    args = ap.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f} (2 cores)")
    found = measure(args.rounds)
    for on, a in found.items():
        print(
            f"{'skip' if on else 'no skip'}: {len(a)} changes; per change (median) style recalculations "
            f"{np.median(a[:, 0]):.0f} ({1e3 * np.median(a[:, 1]):.1f} ms), script {1e3 * np.median(a[:, 2]):.1f} ms, "
            f"layouts {np.median(a[:, 3]):.0f}; the browser's part p50 / p95 {np.median(a[:, 4]):.1f} / "
            f"{np.percentile(a[:, 4], 95):.1f} ms; slider → redrawn p50 / p95 {np.median(a[:, 5]):.1f} / "
            f"{np.percentile(a[:, 5], 95):.1f} ms"
        )
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
