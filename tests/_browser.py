"""Shared by the browser tests: Debian's chromium through Playwright, and the dashboard served as users serve it.

``dashboard(url)`` opens a chromium page on it and waits for the first plot's data; ``new_page()`` opens a blank one;
``NAMED`` / ``PLOT_DATA`` are the page-side functions the tests wait on. A test module's pages share one chromium
(:func:`browser`), each page in a fresh context of its own (cookies, storage and cache), as a new browser would be.
"""

from __future__ import annotations

import contextlib
import socket
import subprocess
import time
import urllib.request
from pathlib import Path

__all__ = [
    "ARGS",
    "CHROMIUM",
    "DEEP",
    "NAMED",
    "PLOT_DATA",
    "ROOT",
    "TAB_OPEN",
    "browser",
    "close_browser",
    "dashboard",
    "free_port",
    "launch",
    "new_page",
    "wait_http",
]

CHROMIUM = Path("/usr/bin/chromium")
ROOT = Path(__file__).resolve().parent.parent
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]


def launch(p):
    """Debian's chromium, headless: a missing browser fails the test (./scripts/test installs it), never skips it."""
    assert CHROMIUM.exists(), "Debian's chromium is not installed at /usr/bin/chromium: run ./scripts/test"
    return p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)


#: the running test module's Playwright and chromium (:func:`browser`), empty between modules
_SHARED: dict = {}


def browser():
    """The chromium of the running test module: launched at its first use, reused by the module's later tests (a
    fresh context costs a fraction of a launch) and closed by :func:`close_browser` when the module ends
    (``tests/conftest.py``); launched again if it has gone. One per module rather than per session: a started
    Playwright keeps its event loop on the thread, where a later module's ``asyncio.run`` would find it running."""
    from playwright import sync_api

    shared = _SHARED.get("browser")
    if shared is None or not shared.is_connected():
        close_browser()
        _SHARED["playwright"] = sync_api.sync_playwright().start()
        _SHARED["browser"] = launch(_SHARED["playwright"])
    return _SHARED["browser"]


def close_browser() -> None:
    """Close the module's chromium and stop its Playwright, if :func:`browser` started them."""
    shared, playwright = _SHARED.pop("browser", None), _SHARED.pop("playwright", None)
    try:
        if shared is not None and shared.is_connected():
            shared.close()
    finally:
        if playwright is not None:
            playwright.stop()


@contextlib.contextmanager
def new_page(viewport: dict | None = None):
    """A blank page of the module's chromium in a context of its own (as a new browser's), closed afterwards."""
    context = browser().new_context(viewport=viewport or {"width": 1600, "height": 1000})
    try:
        yield context.new_page()
    finally:
        context.close()


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


@contextlib.contextmanager
def dashboard(url: str, on_request=None, viewport: dict | None = None, ready: str = ""):
    """A chromium page with the dashboard at ``url`` open and its first plot drawn — or, for a link that opens another
    tab, ``ready`` (a page-side function) true — (``on_request(url)`` sees every request from the start); the test
    fails if the page raised a script error meanwhile."""
    from playwright import sync_api

    errors: list[str] = []
    with new_page(viewport) as page:
        if on_request is not None:
            page.on("request", lambda request: on_request(request.url))
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.goto(url)
        try:
            page.wait_for_function(ready or PLOT_DATA, timeout=30_000)
        except sync_api.TimeoutError:
            models = page.evaluate("() => window.Bokeh ? Bokeh.documents.map(d => d._all_models.size) : null")
            raise AssertionError(
                f"no plot data within 30 s; page errors: {errors}; models: {models}; "
                f"page text: {page.inner_text('body')[:300]!r}"
            ) from None
        yield page
    # e.g. "reference p… isn't known": the browser dropped a change of the page (parts of it then stay empty)
    assert not errors, errors


#: ``named(name)``: the model of that name in the page's document, or null — also while a patch is being applied, when
#: bokeh's get_model_by_name throws on a model whose properties are not set yet ("… name is unset")
NAMED = """(name) => { try { const d = window.Bokeh && Bokeh.documents[0];
                           return d ? d.get_model_by_name(name) : null; }
                     catch (e) { return null; } }"""

#: ``deep(selector)``: the first element matching ``selector`` in the page, shadow roots included (Panel and BokehJS
#: draw every component in a shadow root of its own, nested), or null
DEEP = """(selector) => { const walk = (root) => { const hit = root.querySelector(selector); if (hit) return hit;
        for (const el of root.querySelectorAll('*')) { if (el.shadowRoot) { const h = walk(el.shadowRoot);
            if (h) return h; } } return null; };
    return walk(document); }"""

#: ``tab_open(title)``: the page's open tab is the one titled so and its panel has content
TAB_OPEN = """(title) => { if (!window.Bokeh || !Bokeh.index) return false;
    const tabs = Array.from(Bokeh.index.all_views()).find(v => v.header_els && v.model.type.endsWith('Tabs'));
    return Boolean(tabs && tabs.model.tabs[tabs.model.active].title === title
        && tabs.child_views[tabs.model.active] && tabs.child_views[tabs.model.active].el.isConnected); }"""

PLOT_DATA = f"""() => {{
    const src = ({NAMED})('traj-1-isl');
    if (!src || src.data.y.length === 0) return null;
    return Array.from(src.data.y.slice(0, 50)).join(',');
}}"""

#: per plot, the band's drawn offsets from X̂ᵢ as BokehJS computed them: [min, max] of upper − y and of y − lower
BAND_OFFSETS = """() => Array.from(Bokeh.index.all_views()).filter(v => v.model.type === 'Band' && v._upper)
    .map(v => { const y = v.model.source.data.y, up = v._upper, lo = v._lower;
        let a = Infinity, b = -Infinity, c = Infinity, d = -Infinity;
        for (let k = 0; k < y.length; k++) { const u = up[k] - y[k], l = y[k] - lo[k];
            a = Math.min(a, u); b = Math.max(b, u); c = Math.min(c, l); d = Math.max(d, l); }
        return [v.model.source.name, y.length, a, b, c, d]; })"""


#: the scenario plots' legend labels as BokehJS holds them (what its legends draw), and their time axes' labels
SCENARIO_TEXT = """() => Array.from(Bokeh.index.all_views()).filter(v => v.model.type === 'Figure' && v.model.title
        && /clairvoyant|σ\\(t\\)/.test(v.model.title.text))
    .map(v => [v.model.title.text, [...v.model.right, ...v.model.below].filter(m => m.type === 'Legend')
        .flatMap(l => l.items.map(i => i.label.value)), v.model.below.map(a => a.axis_label)])"""
