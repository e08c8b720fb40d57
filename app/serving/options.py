"""The server's command line: ``isl serve``'s options, their environment variables and defaults, and their checks.

Run as ``isl serve``, ``python -m app.serving`` or ``./scripts/serve``; ``--help`` lists the options. Every option
also has an environment variable, so a container is configured at ``docker run`` time:

==============================  =======================  ====================================================
option                          environment              default
==============================  =======================  ====================================================
``--address``                   ``ISL_ADDRESS``          ``127.0.0.1`` (this machine only; the image: 0.0.0.0)
``--port``                      ``ISL_PORT``             5006
``--allow-websocket-origin``    ``ISL_ALLOWED_ORIGINS``  ``localhost:PORT,127.0.0.1:PORT``; never ``*``
``--num-procs``                 ``ISL_NUM_PROCS``        0: one process per usable core (:ref:`serving-many`)
``--num-threads``               ``ISL_NUM_THREADS``      4 threads run the callbacks (the kernel is nogil)
``--unused-session-lifetime``   —                        10 s after the last connection closes
``--check-unused-sessions``     —                        2 s between sweeps for unused sessions
``--stats-interval``            —                        60 s between ``isl stats`` log lines
``--trim-interval``             —                        5 s between looks for ended sessions' memory
``--stall-log``                 —                        log each long stall of the event loop, with its cause
==============================  =======================  ====================================================
"""

from __future__ import annotations

import argparse
import os

from app.serving.memory import TRIM_INTERVAL_MS

__all__ = [
    "CHECK_UNUSED_SESSIONS_MS",
    "DEFAULT_ADDRESS",
    "DEFAULT_NUM_THREADS",
    "DEFAULT_PORT",
    "ENV",
    "STALL_LOG_MS",
    "STATS_INTERVAL_MS",
    "UNUSED_SESSION_LIFETIME_MS",
    "build_parser",
    "check_counts",
]

DEFAULT_ADDRESS = "127.0.0.1"
DEFAULT_PORT = 5006
DEFAULT_NUM_THREADS = 4
UNUSED_SESSION_LIFETIME_MS = 10_000
CHECK_UNUSED_SESSIONS_MS = 2_000
STATS_INTERVAL_MS = 60_000
STALL_LOG_MS = 250  #: a stall of the event loop this long is logged with what held it (app.serving.stalls)
ENV = {
    "address": "ISL_ADDRESS",
    "port": "ISL_PORT",
    "origins": "ISL_ALLOWED_ORIGINS",
    "frames": "ISL_FRAME_ANCESTORS",
    "num_procs": "ISL_NUM_PROCS",
    "num_threads": "ISL_NUM_THREADS",
}


def _env_int(name: str, default: int) -> int:
    value = os.environ.get(name, "").strip()
    if not value:
        return default
    try:
        return int(value)
    except ValueError:
        raise SystemExit(f"{name} must be an integer, got {value!r}") from None


def check_counts(opts: argparse.Namespace) -> None:
    """``ValueError`` naming the option if a port, process, thread or interval count is out of range."""
    limits = {
        "port": (1, 65535),
        "num_procs": (0, 256),
        "num_threads": (1, 256),
        "unused_session_lifetime": (100, 10**8),
        "check_unused_sessions": (100, 10**8),
        "stats_interval": (0, 10**8),
        "trim_interval": (100, 10**8),
        "stall_log": (0, 10**8),
    }
    for name, (lo, hi) in limits.items():
        value = getattr(opts, name)
        if not lo <= value <= hi:
            raise ValueError(f"--{name.replace('_', '-')} must be an integer in [{lo}, {hi}], got {value}")


def _add_housekeeping(p: argparse.ArgumentParser) -> None:
    """The intervals, in milliseconds, at which the server looks after its sessions, its memory and its loop."""
    g = p.add_argument_group("housekeeping (milliseconds)")
    g.add_argument(
        "--unused-session-lifetime",
        type=int,
        default=UNUSED_SESSION_LIFETIME_MS,
        metavar="MS",
        help=f"how long a session outlives its last connection (default {UNUSED_SESSION_LIFETIME_MS})",
    )
    g.add_argument(
        "--check-unused-sessions",
        type=int,
        default=CHECK_UNUSED_SESSIONS_MS,
        metavar="MS",
        help=f"interval of the sweep for unused sessions (default {CHECK_UNUSED_SESSIONS_MS})",
    )
    g.add_argument(
        "--stats-interval",
        type=int,
        default=STATS_INTERVAL_MS,
        metavar="MS",
        help=f"log live sessions, connections and RSS this often, 0 = never (default {STATS_INTERVAL_MS})",
    )
    g.add_argument(
        "--trim-interval",
        type=int,
        default=TRIM_INTERVAL_MS,
        metavar="MS",
        help=f"how often to look for ended sessions and hand their memory back (default {TRIM_INTERVAL_MS})",
    )
    g.add_argument(
        "--stall-log",
        type=int,
        default=STALL_LOG_MS,
        metavar="MS",
        help=f"log each stall of the event loop of at least MS, with what held it, 0 = never (default {STALL_LOG_MS})",
    )


def build_parser() -> argparse.ArgumentParser:
    """The ``isl serve`` / ``python -m app.serving`` command line."""
    p = argparse.ArgumentParser(prog="isl serve", description="Serve the isl dashboard with safe defaults.")
    p.add_argument(
        "--address",
        default=os.environ.get(ENV["address"], DEFAULT_ADDRESS),
        help=f"interface to listen on; 0.0.0.0 for every interface (env {ENV['address']}, default {DEFAULT_ADDRESS})",
    )
    p.add_argument(
        "--port",
        type=int,
        default=_env_int(ENV["port"], DEFAULT_PORT),
        help=f"port to listen on, 1..65535 (env {ENV['port']}, default {DEFAULT_PORT})",
    )
    p.add_argument(
        "--allow-websocket-origin",
        action="append",
        default=[],
        metavar="HOST[:PORT]",
        help=f"a host a browser may open the dashboard from (repeatable; added to env "
        f"{ENV['origins']}, comma-separated; default localhost and 127.0.0.1 on PORT)",
    )
    p.add_argument(
        "--num-procs",
        type=int,
        default=_env_int(ENV["num_procs"], 0),
        help=f"server processes, 0 = one per usable core (env {ENV['num_procs']}, default 0)",
    )
    p.add_argument(
        "--num-threads",
        type=int,
        default=_env_int(ENV["num_threads"], DEFAULT_NUM_THREADS),
        help=f"threads per process that run callbacks and simulations (env {ENV['num_threads']}, "
        f"default {DEFAULT_NUM_THREADS})",
    )
    _add_housekeeping(p)
    p.add_argument(
        "--frame-ancestors",
        action="append",
        default=[],
        metavar="SITE",
        help=f"a site that may show the dashboard in a frame, e.g. https://lms.example.edu (repeatable; "
        f"added to env {ENV['frames']}; default: none, only the dashboard itself)",
    )
    p.add_argument("--log-level", default="info", choices=["debug", "info", "warning", "error", "critical"])
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--check", action="store_true", help="run the warm-up (numba cache, the app once) and exit")
    mode.add_argument("--health", action="store_true", help="exit 0 if a local server answers /liveness, else 1")
    return p
