"""Serve the dashboard: ``panel serve app/app.py`` with safe defaults.

Run as ``isl serve``, ``python -m app.serving`` or ``./scripts/serve``; its options and their environment
variables are :mod:`!app.serving.options`'s (``--help`` lists them).

Always on: ``GET /liveness`` (200 while the server's event loop answers; :mod:`!app.serving.webguard`, with the
security headers, the host check and compression), the built documentation at ``/docs/`` (:mod:`!app.serving.docs`),
``--warm`` (the app runs once before the port opens), a global exception handler and per-session release hooks
(:mod:`!app.serving.hardening`), pages built off the event loop (:mod:`!app.serving.offloop`) and memory handed back
after a class (:mod:`!app.serving.memory`).
Never on: ``--admin``, ``--dev``/``--autoreload``, a ``*`` websocket origin.

Why in-process: this module builds the argument list of ``panel serve`` and runs Panel's own ``serve``
sub-command in this process (the code path of the ``panel`` executable, so every flag means what Panel
documents), rather than spawning ``panel serve`` as a child. That lets it

* install the patches of Panel and Bokeh (:mod:`!app.serving.patches`) in the serving process before any session
  exists, so the exception handler and the traceback-free websocket error replies cover every session;
* make ``--warm`` strict: Panel logs a failing app script and serves an empty page anyway; here the failure of
  the warm-up run ends the process with exit code 1, so a broken image never reports healthy;
* print the URL once the port is bound and return an exit code to ``isl serve``;
* stay one command for a container: PID 1 receives ``docker stop``'s SIGTERM directly and, with several worker
  processes, passes it on to each of them (:mod:`!app.serving.workers`).

With several processes (the default: one per usable core), the page's HTML is answered from pages built once per
process at start-up (Panel's ``--reuse-sessions``, :mod:`!app.serving.pages`), and a session's own page is built
only when its websocket connects, in the process that accepted it: the operating system spreads connections over
the processes, and a page request and its websocket may reach different ones; building at the websocket means that
each page is built once, where its session lives (:ref:`serving-cores`). Long jobs take one slot for the whole server
(:func:`!app.jobs.long.machine_slot`), not one per process.

``--check`` runs the warm-up only (a small simulation to fill the numba cache, then the app once) and exits:
the Docker build uses it. ``--health`` asks ``/liveness`` of a local server and exits 0/1: the image's
HEALTHCHECK uses it (no curl in a slim image).
"""

from __future__ import annotations

import argparse
import contextlib
import faulthandler
import logging
import os
import sys
import urllib.request
from collections.abc import Sequence
from importlib.util import find_spec

from app.serving import workers
from app.serving.memory import TRIM_INTERVAL_MS, MemoryTrimmer, check_allocator, freeze_warm_heap, log_stats
from app.serving.options import (
    ENV,
    STALL_LOG_MS,
    build_parser,
    check_counts,
)
from app.serving.warmup import AppStartupError, check_app, raise_if_failed, warm_core, warm_long_jobs

log = logging.getLogger("isl.serve")

# Clients only send widget changes and small events; cap what one websocket message may carry (tornado: 20 MB).
WEBSOCKET_MAX_MESSAGE_BYTES = 2 * 1024 * 1024
LIVENESS_ENDPOINT = "liveness"
# Bokeh reads this variable and lets it REPLACE the allow-list; the origins come from ISL_ALLOWED_ORIGINS only.
BOKEH_ORIGIN_ENV = "BOKEH_ALLOW_WS_ORIGIN"


SWITCH_INTERVAL_S = 0.0005  #: how long a thread may keep the interpreter lock when another wants it (see serve)


def app_script() -> str:
    """Path of ``app/app.py`` inside the installed (or checked-out) package, found without importing it."""
    spec = find_spec("app.app")
    if spec is None or spec.origin is None:
        raise AppStartupError("cannot find the dashboard module app/app.py")
    return spec.origin


def allowed_origins(port: int, spec: str | None, extra: Sequence[str] = ()) -> list[str]:
    """Websocket origins ``host[:port]`` from a comma-separated ``spec`` plus ``extra``.

    With neither, only this machine's browser: ``localhost:PORT`` and ``127.0.0.1:PORT``. A ``*`` host (any site
    may open a session in a visitor's browser) and URLs with a scheme are refused with a ``ValueError``.
    """
    entries = [e.strip() for e in (spec or "").split(",") if e.strip()] + [e.strip() for e in extra if e.strip()]
    if not entries:
        return [f"localhost:{port}", f"127.0.0.1:{port}"]
    for entry in entries:
        host, _, entry_port = entry.partition(":")
        if "/" in entry or not host:
            raise ValueError(f"websocket origin must be host[:port] (no scheme, no path), got {entry!r}")
        if host.strip("*.") == "":
            raise ValueError(f"websocket origin must name a host, a bare wildcard is refused: {entry!r}")
        if entry_port and not (entry_port == "*" or entry_port.isdigit()):
            raise ValueError(f"websocket origin port must be a number, got {entry!r}")
    return list(dict.fromkeys(entries))


def panel_argv(opts: argparse.Namespace, script: str, origins: Sequence[str]) -> list[str]:
    """Arguments for Panel's ``serve`` sub-command (without the leading ``serve``)."""
    argv = [
        script,
        "--address",
        opts.address,
        "--port",
        str(opts.port),
        "--num-procs",
        str(opts.num_procs),
        "--num-threads",
        str(opts.num_threads),
        "--unused-session-lifetime",
        str(opts.unused_session_lifetime),
        "--check-unused-sessions",
        str(opts.check_unused_sessions),
        "--websocket-max-message-size",
        str(WEBSOCKET_MAX_MESSAGE_BYTES),
        "--log-level",
        opts.log_level,
        "--warm",
        "--reuse-sessions",  # the page's HTML from a page built at start-up; its own page built at its websocket
    ]  # /liveness: webguard's (Panel's can build a session)
    for origin in origins:
        argv += ["--allow-websocket-origin", origin]
    return argv


def browser_url(address: str, port: int) -> str:
    """The URL to open: loopback and wildcard addresses are reached as ``localhost``."""
    host = "localhost" if address in ("", "0.0.0.0", "::", "127.0.0.1", "::1", "localhost") else address
    return f"http://{host}:{port}/"


def _serve_command(
    origins: Sequence[str],
    stats_interval_ms: int,
    ancestors: Sequence[str] = (),
    trim_interval_ms: int = TRIM_INTERVAL_MS,
    stall_log_ms: int = STALL_LOG_MS,
):
    """Panel's ``serve`` sub-command with a strict warm-up and a URL banner (imports panel lazily)."""
    from panel.command.serve import Serve

    class StrictServe(Serve):
        def customize_applications(self, args, applications):
            from app.serving.offloop import OffLoopApplication

            # the app script runs on a page-building thread, not on the event loop (bokeh's public hook for the
            # applications it serves); Panel's index route and the page's route share one application
            applications = super().customize_applications(args, applications)
            served = {}  # by id: one of ours for each application Panel built
            for application in applications.values():
                if id(application) not in served:
                    served[id(application)] = OffLoopApplication.like(application)
            return {path: served[id(application)] for path, application in applications.items()}

        def warm_applications(self, applications, *args, **kwargs):
            super().warm_applications(applications, *args, **kwargs)
            raise_if_failed(applications.values())

        def customize_server(self, server):
            from tornado.process import task_id

            from app.serving import pages

            if task_id() in (None, 0):  # first: another process may answer before this one is ready
                print(
                    f"isl dashboard: {browser_url(server.address or '', server.port)}  (listening on "
                    f"{server.address}:{server.port}; websocket origins: {', '.join(origins)}; "
                    f"set {ENV['origins']} to add hosts)",
                    flush=True,
                )
            # The pages this process answers HTML requests from, built here in each process (before a fork, Panel's
            # warm-up may not run the app: bokeh forks only a process where no app code ran).
            pages.build_pages({path: c.application for path, c in server._tornado._applications.items()})
            warm_long_jobs()  # in each process: a fork server and the queue's thread do not survive a fork
            from tornado.ioloop import PeriodicCallback

            if stats_interval_ms > 0:
                PeriodicCallback(lambda: log_stats(server), stats_interval_ms).start()
            freeze_warm_heap()
            PeriodicCallback(MemoryTrimmer(server), trim_interval_ms).start()
            from app.serving import webguard

            webguard.install(server._tornado, origins, ancestors)  # headers, host check, gzip, /liveness
            from app.serving import static

            static.install(server._tornado)  # static files compressed once, on a thread (the transform: on the loop)
            from app.serving import docs

            docs.install(server._tornado)  # the built documentation at /docs/ (ISL_DOCS_DIR)
            from app.serving.hardening import quiet_closed_websockets, quiet_error_replies

            quiet_closed_websockets(server.io_loop.asyncio_loop)  # a tab closed mid-write is not an error
            quiet_error_replies(server._tornado)  # no traceback, no internal text in a websocket ERROR reply
            from app.serving import stalls

            stalls.watch(server.io_loop.asyncio_loop, stall_log_ms / 1000)  # what held the loop, when it stalls
            return super().customize_server(server)

    return StrictServe


def health(port: int, timeout: float = 3.0) -> int:
    """0 if ``http://127.0.0.1:PORT/liveness`` answers 200, else 1."""
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/{LIVENESS_ENDPOINT}", timeout=timeout) as r:
            return 0 if r.status == 200 else 1
    except OSError:
        return 1


def serve(opts: argparse.Namespace, origins: Sequence[str], ancestors: Sequence[str] = ()) -> int:
    """Serve until interrupted; 1 if the app fails its warm-up or the port cannot be bound."""
    if os.environ.pop(BOKEH_ORIGIN_ENV, None) is not None:
        log.warning("ignoring %s; set %s instead", BOKEH_ORIGIN_ENV, ENV["origins"])
    check_allocator()
    # The event loop's thread releases the interpreter lock at every file-system call of Panel's page building
    # (several a component) and, beside compute threads running Python, waits up to the switch interval to get it
    # back each time: a short SWITCH_INTERVAL_S bounds that wait, so a page's build does not stall the loop
    # (:ref:`performance-warm-up`).
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    warm_core()  # before the fork: the kernels compiled once, their memory shared by the processes
    opts.num_procs = opts.num_procs or workers.usable_cores()
    if opts.num_procs > 1:
        workers.install()  # SIGTERM and SIGINT reach every process; a start-up failure stops them all
    slot = workers.long_job_slot()  # one long job at a time for the whole server (app.jobs.long.machine_slot)
    argv = panel_argv(opts, app_script(), origins)
    parser = argparse.ArgumentParser(prog="panel serve")
    command = _serve_command(origins, opts.stats_interval, ancestors, opts.trim_interval, opts.stall_log)(parser=parser)
    args = parser.parse_args(argv)
    try:
        command.invoke(args)
    except AppStartupError as exc:
        log.error("%s", exc)
        return workers.STARTUP_FAILED if workers.is_worker() else 1
    except SystemExit as exc:  # bokeh exits 1 when the port is in use; the parent of the workers exits with them
        return exc.code if isinstance(exc.code, int) else 1
    except KeyboardInterrupt:
        pass
    finally:
        slot.close()
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``isl serve`` and ``python -m app.serving``; returns the exit code."""
    opts = build_parser().parse_args(argv)
    logging.basicConfig(format="%(asctime)s %(name)s %(levelname)s %(message)s")
    logging.getLogger("isl").setLevel(opts.log_level.upper())
    try:
        check_counts(opts)
        origins = allowed_origins(opts.port, os.environ.get(ENV["origins"]), opts.allow_websocket_origin)
        from app.serving.webguard import check_frame_ancestors

        named = filter(None, [os.environ.get(ENV["frames"]), *opts.frame_ancestors])
        ancestors = check_frame_ancestors(" ".join(named))
    except ValueError as exc:
        log.error("%s", exc)
        return 2
    if opts.health:
        return health(opts.port)
    # a crash in native code (a kernel, a library) writes every thread's Python stack to the log before the process
    # ends, where it would otherwise end with a signal and no word of where (not when there is no standard error to
    # write to: the server starts all the same)
    with contextlib.suppress(RuntimeError, ValueError, OSError):
        faulthandler.enable(all_threads=True)
    from app.serving import patches

    patches.install()  # once, before any session exists: the Python patches of Panel and Bokeh (docs: development)
    if opts.check:
        try:
            warm_core()
            warm_long_jobs()
            check_app(app_script())
        except AppStartupError as exc:
            log.error("%s", exc)
            return 1
        print("isl dashboard: warm-up passed", flush=True)
        return 0
    return serve(opts, origins, ancestors)
