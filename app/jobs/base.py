"""What the session's jobs and the server's long jobs share: an outcome, CPU priorities, the ways a job ends early.

:mod:`app.jobs.threads` runs a session's jobs on thread pools, :mod:`app.jobs.long` the server's queue of long jobs
in child processes; both import this module and neither imports the other.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from isl_core.jobs import Cancelled

__all__ = [
    "LARGE_NICE",
    "LONG_NICE",
    "PAGE_NICE",
    "RUN_NICE",
    "Cancelled",
    "Outcome",
    "QueueFull",
    "call",
    "in_steps",
    "lower_priority",
]

log = logging.getLogger(__name__)

#: CPU priority of the threads building a new page or a tab's part: someone waits for it, but below the event loop
#: (nice 0), which answers every session and ``/liveness``
PAGE_NICE = 2
RUN_NICE = 5  #: of the threads computing runs: below the page builds
LARGE_NICE = 8  #: of the thread computing large runs (over LIVE_MAX_STEPS steps): below the slider runs
LONG_NICE = 10  #: and of the thread computing long jobs (sweeps, worst cases, recommendations): below the runs


def lower_priority(nice: int) -> Callable[[], None]:
    """A thread initializer that sets the calling thread's CPU priority ``nice`` below the process's (Linux: threads
    are scheduled one by one, and a thread may lower its own priority without privileges; elsewhere: nothing).

    The event loop of a served dashboard answers every session and ``/liveness``; among compute threads of its own
    priority it gets a small share of the cores. With the other threads niced, the kernel still gives them every idle
    cycle, but the loop runs first. The base is the process's priority (its main thread's, where the loop runs), not
    that of the thread which happened to start the pool's thread: a page being built (itself niced) submits the page's
    first run, and would otherwise start a run thread at the sum of both.
    """

    def initializer() -> None:
        try:
            base = os.getpriority(os.PRIO_PROCESS, os.getpid())  # the main thread's (Linux: a thread's own with 0)
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), min(19, base + nice))
        except (AttributeError, OSError):  # not Linux, or not allowed: same priority as the loop
            log.debug("could not lower a worker thread's priority", exc_info=True)

    return initializer


class QueueFull(RuntimeError):
    """Too many long jobs are waiting, or this session has one already; the message says which."""


@dataclass(frozen=True)
class Outcome:
    """What a job returned or raised, and its wall-clock time in seconds."""

    value: Any = None
    error: BaseException | None = None
    seconds: float = 0.0


def call(fn: Callable[[], Any]) -> Outcome:
    """Run ``fn`` and capture its value or exception (exceptions must cross the thread boundary as data)."""
    t0 = time.perf_counter()
    try:
        value = fn()
    except Exception as exc:  # noqa: BLE001 — every failure becomes a message, the server keeps serving
        return Outcome(error=exc, seconds=time.perf_counter() - t0)
    return Outcome(value=value, seconds=time.perf_counter() - t0)


def in_steps(report: Callable[[float], None], step: float = 0.01) -> Callable[[float], None]:
    """``report`` called only when the progress fraction has moved by ``step`` since its last call, or reached 1
    (a job reports per chunk; a page or a pipe needs no more than 1 % steps)."""
    last = [0.0]

    def progress(fraction: float) -> None:
        if fraction - last[0] >= step or fraction >= 1.0:
            last[0] = fraction
            report(fraction)

    return progress
