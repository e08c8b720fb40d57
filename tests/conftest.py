"""Fixtures shared by the test modules: ``app_server``, the dashboard served as users serve it, once per module."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest
from _browser import ROOT, free_port, wait_http


@pytest.fixture(scope="session", autouse=True)
def _own_tuning_cache(tmp_path_factory):
    """No test reads or writes the user's cache of tunings (isl_core.tuning.cache_dir): one of the session's own."""
    old = os.environ.get("ISL_CACHE_DIR")
    os.environ["ISL_CACHE_DIR"] = str(tmp_path_factory.mktemp("isl-cache"))
    yield
    if old is None:
        os.environ.pop("ISL_CACHE_DIR", None)
    else:
        os.environ["ISL_CACHE_DIR"] = old


@pytest.fixture(scope="module")
def app_server(tmp_path_factory):
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


def pytest_collection_modifyitems(session, config, items) -> None:
    """Test files with a slow or a browser test run first (each file's own order kept): with the files spread over
    pytest-xdist's workers (./scripts/test), the long ones then overlap instead of running last, side by side."""
    heavy = {item.path for item in items if item.get_closest_marker("slow") or item.get_closest_marker("browser")}
    items.sort(key=lambda item: item.path not in heavy)
