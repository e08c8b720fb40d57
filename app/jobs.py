"""Background jobs of one dashboard session: compute off the event loop, apply on it, coalesce requests.

A slider drag fires dozens of changes a second; only the newest matters. :class:`Jobs` keeps, per job
kind (``"run"``, ``"sweep"``, …), at most one computation in flight and at most one waiting: a new request
replaces the waiting one. Computations run on a thread pool (the compiled kernel releases the GIL, so two
sessions' runs proceed in parallel and no session's event loop waits for another's sweep); their outcome is
handed back through ``schedule`` — in a served app, a callback on the session's own event loop with the
document lock held — so the state and the plots are only ever touched from that loop.

Without an executor (tests, scripts) a job runs inline and its outcome is applied at once.
"""
from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from concurrent.futures import Executor, ThreadPoolExecutor
from dataclasses import dataclass
from functools import partial
from typing import Any

__all__ = ["RUN_POOL", "SWEEP_POOL", "Jobs", "Outcome", "call"]

log = logging.getLogger(__name__)

#: Shared by every session of a server process: short runs, and long sweeps kept apart so that a sweep
#: never queues a slider update behind it.
RUN_POOL = ThreadPoolExecutor(max_workers=4, thread_name_prefix="isl-run")
SWEEP_POOL = ThreadPoolExecutor(max_workers=2, thread_name_prefix="isl-sweep")


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


def _inline(fn: Callable[[], None]) -> None:
    fn()


class Jobs:
    """Per-session job runner: one in flight and one waiting per kind; outcomes applied via ``schedule``.

    ``executor`` None runs every job inline. ``schedule(fn)`` must run ``fn`` later on the session's event
    loop; it is called from worker threads.
    """

    def __init__(self, executors: dict[str, Executor] | None = None,
                 schedule: Callable[[Callable[[], None]], None] | None = None) -> None:
        self._executors = executors or {}
        self._schedule = schedule or _inline
        self._busy: set[str] = set()
        self._waiting: dict[str, tuple[Callable[[], Any], Callable[[Outcome, bool], None]]] = {}
        self._lock = threading.Lock()  # `panel serve --num-threads` runs widget callbacks on several threads
        self.closed = False

    def busy(self, kind: str) -> bool:
        return kind in self._busy

    def submit(self, kind: str, fn: Callable[[], Any], done: Callable[[Outcome, bool], None]) -> None:
        """Compute ``fn()`` off the loop, then call ``done(outcome, superseded)`` on it.

        ``superseded`` is True when a newer request of the same kind is already waiting.
        """
        if self.closed:
            return
        executor = self._executors.get(kind)
        if executor is None:
            done(call(fn), False)
            return
        with self._lock:
            if kind in self._busy:
                self._waiting[kind] = (fn, done)
                return
            self._busy.add(kind)
        self._start(kind, executor, fn, done)

    def _start(self, kind: str, executor: Executor, fn, done) -> None:
        future = executor.submit(call, fn)
        future.add_done_callback(lambda f: self._deliver(partial(self._finish, kind, executor, done, f.result())))

    def later(self, fn: Callable[[], None]) -> None:
        """Run ``fn`` on the session's loop (callable from any thread); dropped once the session has closed."""
        if not self.closed:
            self._deliver(fn)

    def _deliver(self, fn: Callable[[], None]) -> None:
        try:
            self._schedule(fn)
        except Exception:
            log.debug("dropped a job outcome: its session has closed", exc_info=True)

    def _finish(self, kind: str, executor: Executor, done, outcome: Outcome) -> None:
        with self._lock:
            waiting = self._waiting.pop(kind, None)
            if waiting is None or self.closed:
                self._busy.discard(kind)
        try:
            if not self.closed:
                done(outcome, waiting is not None)
        finally:  # even if applying the outcome failed, the newest request must still run
            if waiting is not None and not self.closed:
                self._start(kind, executor, *waiting)

    def close(self) -> None:
        """Forget waiting requests and drop outcomes still to come (the session has ended)."""
        with self._lock:
            self.closed = True
            self._waiting.clear()
