"""Shared by every test folder: the helpers' folder on ``sys.path``, a marker per layer, and the fixtures.

Tests live in folders by layer (``tests/core``, ``tests/app``, ``tests/serving``, ``tests/browser``,
``tests/deploy``); each test is marked with its folder's layer (:data:`LAYERS`) — ``pytest -m core`` or
``pytest tests/core`` runs the numerical core alone — and the core's doctests (``isl_core/``) count as ``core``.
The helpers (``_browser``, ``_serving``, ``_loop``) sit in ``tests/`` and are importable from any folder.
Fixtures: ``app_server``, the dashboard served as users serve it, once per pytest-xdist worker; a test module's
pages share one chromium (``_browser.browser``).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import settings
from xdist.scheduler import LoadFileScheduling

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:  # the shared helpers, whichever folder a test module sits in
    sys.path.insert(0, str(HERE))

from _browser import ROOT, close_browser, free_port, wait_http  # noqa: E402  (after the path above)

LAYERS = ("core", "app", "serving", "browser", "deploy")  #: test folders, each a marker of the same name

#: every property test draws the same examples on every run (a failure is seen again, never by luck) and has no
#: deadline (the machine's load is not the code's speed); a test's own ``@settings`` add to these
settings.register_profile("isl", derandomize=True, deadline=None)
settings.load_profile("isl")


@pytest.fixture(scope="session", autouse=True)
def _own_tuning_cache(tmp_path_factory):
    """No test reads or writes the user's cache of tunings (isl_core.scenario.tuning.cache_dir): the session's own."""
    old = os.environ.get("ISL_CACHE_DIR")
    os.environ["ISL_CACHE_DIR"] = str(tmp_path_factory.mktemp("isl-cache"))
    yield
    if old is None:
        os.environ.pop("ISL_CACHE_DIR", None)
    else:
        os.environ["ISL_CACHE_DIR"] = old


@pytest.fixture(autouse=True)
def _server_patches(request: pytest.FixtureRequest) -> None:
    """The dashboard's tests that build pages in this process, without the server (``tests/app``), run with the
    patches of Panel and Bokeh that the server's start-up installs (:func:`app.serving.patches.install`, idempotent).
    A fixture of this file rather than a ``conftest.py`` of ``tests/app``: two modules named ``conftest`` in folders
    without ``__init__.py`` collide when the doctests collect them."""
    if request.node.path.is_relative_to(HERE / "app"):
        from app.serving import patches

        patches.install()


class ServerLog:
    """The part of the shared server's log written since a test began (:func:`app_server`): read as a file's text, so a
    test's ``"Traceback" not in log.read_text()`` speaks of its own pages only; ``parent``, the log's folder."""

    def __init__(self, path: Path) -> None:
        self.path, self.parent = path, path.parent
        self.start = path.stat().st_size

    def read_text(self, encoding: str | None = None, errors: str | None = None) -> str:
        with open(self.path, "rb") as log:
            log.seek(self.start)
            return log.read().decode(encoding or "utf-8", errors or "strict")


#: the server's settings from the environment (app.serving.options), left out of the shared server's
SERVING_SETTINGS = ("ISL_ALLOWED_ORIGINS", "ISL_DOCS_DIR", "ISL_FRAME_ANCESTORS", "ISL_NUM_PROCS", "ISL_NUM_THREADS")


@pytest.fixture(scope="session")
def _served_app(tmp_path_factory):
    """The dashboard served as users serve it (``python -m app.serving``: callbacks on its worker threads, long jobs
    in processes, the headers and the host check), started once per pytest-xdist worker at its first use: every
    test opens pages of its own (new sessions) on it, as many users share one server. Its URL and log file."""
    port = free_port()
    log = tmp_path_factory.mktemp("serve") / "panel.log"
    # on its defaults, whatever the shell sets (the tests of the documentation and the frame policy read them)
    env = {k: v for k, v in os.environ.items() if k not in SERVING_SETTINGS}
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")
    cmd = [sys.executable, "-m", "app.serving", "--port", str(port), "--address", "127.0.0.1", "--num-procs", "1"]
    with open(log, "w") as out:
        proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=out, stderr=subprocess.STDOUT)
    try:
        wait_http(f"http://127.0.0.1:{port}/app", proc)
        yield f"http://127.0.0.1:{port}/app", log, proc
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@pytest.fixture
def app_server(_served_app):
    """URL of the served dashboard (:func:`_served_app`) and its log since this test began (:class:`ServerLog`)."""
    url, log, proc = _served_app
    assert proc.poll() is None, f"the shared server has exited (code {proc.returncode}):\n{log.read_text()[-3000:]}"
    return url, ServerLog(log)


@pytest.fixture(scope="module", autouse=True)
def _one_chromium_per_module():
    """The chromium a test module's pages share (``_browser.browser``, launched at first use) closes with it."""
    yield
    close_browser()


def layer(path: Path) -> str | None:
    """The layer of a test at ``path``: its folder under ``tests/`` (:data:`LAYERS`), ``core`` for the core's
    doctests, None for a test outside the layers' folders."""
    if path.is_relative_to(ROOT / "isl_core"):
        return "core"
    if path.is_relative_to(HERE):
        parts = path.relative_to(HERE).parts
        if len(parts) > 1 and parts[0] in LAYERS:
            return parts[0]
    return None


#: test files whose tests each run for tens of seconds: pytest-xdist gives them to the workers one test at a time, so
#: that they run side by side instead of one after the other on one worker (:class:`LongFilesSplit`)
ONE_TEST_AT_A_TIME = (
    "tests/browser/test_browser_property.py",  # a random sequence of 20–40 actions per seed
    "tests/browser/test_browser_jobs.py",  # long jobs clicked in the page, a server of its own for the frame policy
    "tests/deploy/test_dockerfile.py",  # the kernels compiled from a cold cache, once per start-up case
)


def pytest_collection_modifyitems(session, config, items) -> None:
    """Each test gets the marker of its layer (:func:`layer`). The longest work runs first (each file's own order
    kept): the units pytest-xdist hands out (a file, or a test of :data:`ONE_TEST_AT_A_TIME`) with a ``slow`` test,
    then those with a ``browser`` or ``serving`` test (chromium, servers started), then the rest, the many short
    files of the core and the dashboard's state — so that the long ones overlap and the short ones fill the end,
    instead of a long one starting last and ending the run alone."""
    for item in items:
        name = layer(Path(item.path))
        if name is not None:
            item.add_marker(name)
    rank: dict[str, int] = {}
    for item in items:
        busy = item.get_closest_marker("browser") or item.get_closest_marker("serving")  # chromium, servers
        weight = 0 if item.get_closest_marker("slow") else 1 if busy else 2
        unit = LongFilesSplit.unit(item.nodeid)
        rank[unit] = min(rank.get(unit, weight), weight)
    items.sort(key=lambda item: rank[LongFilesSplit.unit(item.nodeid)])


@pytest.hookimpl(optionalhook=True)  # a hook of pytest-xdist's: unknown to a run without it (-p no:xdist)
def pytest_xdist_make_scheduler(config, log):
    """With ``--dist loadfile`` (./scripts/test), pytest-xdist's file scheduling with the long files split
    (:class:`LongFilesSplit`)."""
    if config.getoption("dist", None) == "loadfile":
        return LongFilesSplit(config, log)
    return None


class LongFilesSplit(LoadFileScheduling):
    """pytest-xdist's ``loadfile`` scheduling (a file's tests on one worker, so that its module fixtures are set up
    once), except that each test of :data:`ONE_TEST_AT_A_TIME` is a unit of its own. The units go out in the order
    the tests were collected (``--no-loadscope-reorder``: the longest first, :func:`pytest_collection_modifyitems`)."""

    @staticmethod
    def unit(nodeid: str) -> str:
        """The unit of work a test belongs to: its file, or itself in a file of :data:`ONE_TEST_AT_A_TIME`."""
        path = nodeid.split("::", 1)[0]
        return nodeid if path in ONE_TEST_AT_A_TIME else path

    def _split_scope(self, nodeid: str) -> str:  # pytest-xdist's name for the unit of a test
        return self.unit(nodeid)
