"""The server's warm-up before it listens: the kernels compiled (or loaded from the numba cache), the long jobs'
fork server started, the app script run once in a session (:ref:`performance-warm-up`)."""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from isl_core import Model

__all__ = [
    "AppStartupError",
    "check_app",
    "raise_if_failed",
    "warm_core",
    "warm_long_jobs",
    "warm_model",
    "warm_scenario_loop",
    "warm_view",
]

log = logging.getLogger("isl.serve")


class AppStartupError(RuntimeError):
    """The app script failed during the warm-up run."""


def raise_if_failed(applications) -> None:
    """Raise :class:`AppStartupError` if a handler of ``applications`` failed to run the app script."""
    for application in applications:
        for handler in application.handlers:
            if getattr(handler, "failed", False):
                raise AppStartupError(
                    f"the dashboard app failed during warm-up: {getattr(handler, 'error', 'unknown error')}"
                )


def warm_core() -> None:
    """Compile (or load from the numba cache) every kernel a session calls, each with one short run: the display
    run's (``warm_view``) and the scenario loop's (``warm_scenario_loop``), so that no session compiles one
    while holding the interpreter lock the event loop needs (:ref:`performance-warm-up`)."""
    warm_view()
    warm_scenario_loop()


def warm_model() -> Model:
    """The model of the warm-up's short runs."""
    from isl_core import Model

    return Model.from_w(alpha=0.5, w=3.0, sigma=20.0, m=3)


def warm_view() -> None:
    """The display run's kernels: the simulation and its min/max fold, in one short run."""
    from isl_core.runview import simulate_view

    simulate_view(warm_model(), 3.0, seed=0, horizon=1.0)


def warm_scenario_loop() -> None:
    """The scenario loop's kernel, in one short run."""
    from isl_core import Scenario
    from isl_core.scenario.run import simulate_scenario

    simulate_scenario(warm_model(), 3.0, Scenario(), horizon=1.0, windows=1)


def warm_long_jobs() -> None:
    """Start the fork server the long jobs' processes come from (:mod:`!app.jobs.long`) with one tiny job, so that its
    memory counts in an idle server's. Where no process can be started (no writable temporary directory for the fork
    server's socket, a sandbox without ``fork``), long jobs run on the queue's thread instead, with one log line."""
    import threading

    from app.jobs import in_process, ping
    from app.page import LONG_JOBS

    try:
        answer = in_process(ping, lambda fraction: None, threading.Event())
    except Exception as exc:  # noqa: BLE001
        answer = exc
    if answer != "ok":
        LONG_JOBS.processes = False
        log.warning("long jobs run on a thread of the server: their child process cannot start (%s)", answer)


def check_app(script: str) -> None:
    """Run the app script once in a session, as the server's warm-up does; raise if it fails."""
    import panel  # noqa: F401  (installs Panel's script handler into bokeh)
    from bokeh.command.util import build_single_handler_application
    from panel.io.session import generate_session

    application = build_single_handler_application(script)
    generate_session(application)
    raise_if_failed([application])
