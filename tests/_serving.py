"""Helpers for the tests that start a real server on 127.0.0.1 (serve, Dockerfile, load, hostile, memory, origin).

The websocket client and the server start/stop helpers live in ``scripts/session_client.py``, the load scenario in
``scripts/load_test.py`` (the documented load script); this module imports both and adds a context manager and a
small fixture app.
"""

from __future__ import annotations

import asyncio
import contextlib
import sys
import time
from collections.abc import Iterator
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


sys.path.insert(0, str(REPO / "scripts"))
import load_test  # noqa: E402, F401  (for the tests: the load scenario)
import session_client  # noqa: E402

# A tiny Panel app with the dashboard's moving parts: a slider that redraws a plot, a button whose callback
# fails with a message that must never reach the browser.
FIXTURE_APP = """
import numpy as np
import panel as pn
from bokeh.models import ColumnDataSource
from bokeh.plotting import figure

slider = pn.widgets.FloatSlider(name="sigma", start=0.1, end=10.0, value=1.0)
boom = pn.widgets.Button(name="boom")
source = ColumnDataSource({"x": [0.0], "y": [1.0]})
fig = figure(height=200, width=300)
fig.line("x", "y", source=source)

def redraw(event):
    source.data = {"x": np.arange(10.0), "y": np.full(10, float(event.new))}

def explode(event):
    raise RuntimeError("SECRET-DETAIL in /srv/private/config.py")

slider.param.watch(redraw, "value_throttled")
boom.on_click(explode)
pn.Column(slider, boom, pn.pane.Bokeh(fig)).servable(title="fixture")
"""


def fixture_app(tmp_path: Path) -> str:
    """Write the fixture app as ``app.py`` (so it is served at ``/app`` like the dashboard); its path."""
    path = tmp_path / "fixture" / "app.py"
    path.parent.mkdir(exist_ok=True)
    path.write_text(FIXTURE_APP)
    return str(path)


@contextlib.contextmanager
def served(
    tmp_path: Path, *args: str, script: str | None = None, env: dict | None = None, timeout: float = 180.0
) -> Iterator[tuple[str, object, Path]]:
    """Run ``python -m app.serving`` on a free loopback port; yields (base URL, process, log path); always stops it."""
    port = session_client.free_port()
    log = tmp_path / f"server-{port}.log"
    proc = session_client.start_server(port, log, args, env=env, script=script)
    try:
        session_client.wait_healthy(port, timeout, proc)
        yield f"http://127.0.0.1:{port}", proc, log
    finally:
        session_client.stop_server(proc)


def run(coro, timeout: float = 600.0):
    """Run a coroutine on a fresh event loop, bounded in time."""
    return asyncio.run(asyncio.wait_for(coro, timeout))


def wait_for_log(log: Path, needle: str, timeout: float = 30.0) -> str:
    """The server log once it contains ``needle`` (raises after ``timeout`` s)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        text = log.read_text()
        if needle in text:
            return text
        time.sleep(0.1)
    raise TimeoutError(f"{needle!r} not in the server log after {timeout} s:\n{log.read_text()[-3000:]}")
