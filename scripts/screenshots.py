"""Regenerate the docs' screenshots under docs/images/ from a running dashboard (Debian's chromium via Playwright).

./scripts/serve &                      # or any running server
PYTHONPATH=. .venv/bin/python scripts/screenshots.py [--url http://127.0.0.1:5006/app]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from playwright.sync_api import sync_playwright

DOCS = Path(__file__).resolve().parent.parent / "docs" / "images"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]
PLOT_DATA = """() => { const d = window.Bokeh && Bokeh.documents[0]; const s = d && d.get_model_by_name('traj-1-isl');
                       return !!(s && s.data.y.length > 0); }"""
SCENARIO_DATA = (
    "js:() => { const s = Bokeh.documents[0].get_model_by_name('scenario-ratio'); "
    "return !!(s && s.data.t.length > 0); }"
)
#: file name, window size, query, texts to click in turn, what to wait for then (a CSS selector, "js:" and a
#: function that returns true when the page is ready, or None)
SHOTS = [
    ("default-1280x720.png", (1280, 720), "", (), None),
    ("default-1920x1080.png", (1920, 1080), "", (), None),
    ("presenter-1280x720.png", (1280, 720), "?present=1", (), None),
    ("presenter-1920x1080.png", (1920, 1080), "?present=1", (), None),
    ("sweep-1280x720.png", (1280, 720), "", ("ν sweep (paper A, Fig. 2)",), "text=Simulate points"),
    (
        "errors-m6-1920x1080.png",
        (1920, 1080),
        "?m=6&horizon=100",
        ("Errors (estimate − signal)",),
        "js:() => Bokeh.documents[0].get_model_by_name('traj-1-truth').data.y.length === 2",
    ),
    (
        "errors-m6-1280x720.png",
        (1280, 720),
        "?m=6&horizon=100",
        ("Errors (estimate − signal)",),
        "js:() => Bokeh.documents[0].get_model_by_name('traj-1-truth').data.y.length === 2",
    ),
    ("compare-1920x1080.png", (1920, 1080), "", ("Compare σ", "button:Compare"), "img"),
    ("compare-1280x720.png", (1280, 720), "", ("Compare σ", "button:Compare"), "img"),
    ("scenario-1920x1080.png", (1920, 1080), "", ("Scenarios: σ(t), tails, sensor",), SCENARIO_DATA),
    ("scenario-1280x720.png", (1280, 720), "", ("Scenarios: σ(t), tails, sensor",), SCENARIO_DATA),
]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--url", default="http://127.0.0.1:5006/app")
    url = p.parse_args().url
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
        try:
            for name, (w, h), query, clicks, wait in SHOTS:
                page = browser.new_page(viewport={"width": w, "height": h})
                page.goto(url + query)
                page.wait_for_function(PLOT_DATA, timeout=60_000)
                for text in clicks:  # "button:NAME" is a button, anything else a text
                    (
                        page.get_by_role("button", name=text[7:], exact=True)
                        if text.startswith("button:")
                        else page.get_by_text(text, exact=True)
                    ).click()
                if wait is not None and wait.startswith("js:"):
                    page.wait_for_function(wait[3:], timeout=120_000)
                elif wait is not None:
                    page.locator(wait).first.wait_for(timeout=120_000)
                page.wait_for_load_state("networkidle")
                page.screenshot(path=str(DOCS / name))
                page.close()
                print(f"wrote docs/images/{name}")
        finally:
            browser.close()


if __name__ == "__main__":
    main()
