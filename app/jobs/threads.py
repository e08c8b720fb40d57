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
from collections.abc import Callable, Mapping
from concurrent.futures import Executor, ThreadPoolExecutor
from functools import partial
from typing import Any

from .base import LARGE_NICE, PAGE_NICE, RUN_NICE, Outcome, QueueFull, call, lower_priority

__all__ = ["LARGE_POOL", "RUN_POOL", "VIEW_POOL", "Jobs", "Superseded"]

log = logging.getLogger(__name__)

#: Shared by every session of a server process: runs (a slider's answer) on two threads, large runs (≈ 10⁵–10⁶ steps,
#: followed on release only) on one thread of their own at a lower priority, long jobs in the queue of
#: :mod:`app.jobs.long` (one thread, lower still) — so that no run queues behind a large run or a long job, and each
#: leaves the cores to the work above it.
RUN_POOL = ThreadPoolExecutor(max_workers=2, thread_name_prefix="isl-run", initializer=lower_priority(RUN_NICE))
LARGE_POOL = ThreadPoolExecutor(max_workers=1, thread_name_prefix="isl-large", initializer=lower_priority(LARGE_NICE))
#: builds a tab's part when a user first opens it, at the page builds' priority (PAGE_NICE)
VIEW_POOL = ThreadPoolExecutor(max_workers=2, thread_name_prefix="isl-view", initializer=lower_priority(PAGE_NICE))


class Superseded(Exception):
    """A cancellable job was stopped: a newer request of its kind was waiting, or its session closed."""


def _inline(fn: Callable[[], None]) -> None:
    fn()


class Jobs:
    """Per-session job runner: one in flight and one waiting per kind; outcomes applied via ``schedule``.

    ``executor`` None runs every job inline. ``schedule(fn)`` must run ``fn`` later on the session's event
    loop; it is called from worker threads.
    """

    def __init__(
        self,
        executors: Mapping[str, Executor] | None = None,
        schedule: Callable[[Callable[[], None]], None] | None = None,
        long_queue=None,
    ) -> None:
        self._executors: Mapping[str, Executor] = executors or {}
        self._long = long_queue  # an app.jobs.long.LongJobQueue, shared by the server's sessions (None: inline)
        self._tickets: set = set()
        self._schedule = schedule or _inline
        self._busy: set[str] = set()
        #: per kind, the newest request waiting for the one in flight: (executor, fn, done)
        self._waiting: dict[str, tuple[Executor, Callable[[], Any], Callable[[Outcome, bool], None]]] = {}
        self._lock = threading.Lock()  # `panel serve --num-threads` runs widget callbacks on several threads
        self.closed = False

    def busy(self, kind: str) -> bool:
        return kind in self._busy

    @property
    def long_in_process(self) -> bool:
        """Long jobs compute in child processes (the server's queue, :mod:`app.jobs.long`)."""
        return self._long is not None and self._long.processes

    def submit(
        self,
        kind: str,
        fn: Callable[..., Any],
        done: Callable[[Outcome, bool], None],
        *,
        pool: str | None = None,
        cancellable: bool = False,
    ) -> None:
        """Compute ``fn()`` off the loop (on the executor named ``pool``, default ``kind``), then call
        ``done(outcome, superseded)`` on it.

        ``superseded`` is True when a newer request of the same kind is already waiting. ``cancellable``: ``fn``
        takes ``progress=`` (as the core's simulations do) and is stopped at its next report once a newer request
        is waiting or the session has closed — its outcome is then a :class:`Superseded` error, never shown.
        """
        if self.closed:
            return
        executor = self._executors.get(pool or kind)
        if cancellable:
            fn = partial(fn, progress=partial(self._check, kind))
        if executor is None:
            done(call(fn), False)
            return
        with self._lock:
            if kind in self._busy:
                self._waiting[kind] = (executor, fn, done)
                return
            self._busy.add(kind)
        self._start(kind, executor, fn, done)

    def _check(self, kind: str, fraction: float) -> None:
        """Progress report of a cancellable job: stop it if a newer request of its kind waits, or nobody does."""
        if self.closed or kind in self._waiting:
            raise Superseded(kind)

    def _start(
        self, kind: str, executor: Executor, fn: Callable[[], Any], done: Callable[[Outcome, bool], None]
    ) -> None:
        future = executor.submit(call, fn)
        future.add_done_callback(lambda f: self._deliver(partial(self._finish, kind, done, f.result())))

    def later(self, fn: Callable[[], None]) -> None:
        """Run ``fn`` on the session's loop (callable from any thread); dropped once the session has closed."""
        if not self.closed:
            self._deliver(fn)

    def _deliver(self, fn: Callable[[], None]) -> None:
        try:
            self._schedule(fn)
        except Exception:
            log.debug("dropped a job outcome: its session has closed", exc_info=True)

    def _finish(self, kind: str, done: Callable[[Outcome, bool], None], outcome: Outcome) -> None:
        with self._lock:
            waiting = self._waiting.pop(kind, None)
            if waiting is None or self.closed:
                self._busy.discard(kind)
        try:
            if not self.closed:
                done(outcome, waiting is not None)
        finally:  # even if applying the outcome failed, the newest request must still run
            if waiting is not None and not self.closed:
                self._start(kind, *waiting)

    def submit_long(
        self, fn: Callable[[threading.Event], Any], done: Callable[[Outcome], None], on_position: Callable[[int], None]
    ) -> Callable[[], None]:
        """Queue ``fn(cancel_event)`` as this session's long job (:class:`app.jobs.long.LongJobQueue`); ``done`` and
        ``on_position`` run on the session's loop. Returns a function that cancels it. Inline without a queue."""
        if self.closed:
            return lambda: None
        if self._long is None:
            event = threading.Event()
            done(call(lambda: fn(event)))
            return event.set
        holder: list = []

        def finished(outcome: Outcome) -> None:
            self._tickets.discard(holder[0] if holder else None)
            self._deliver(partial(done, outcome))

        try:
            ticket = self._long.submit(self, fn, finished, lambda ahead: self._deliver(partial(on_position, ahead)))
        except QueueFull as exc:
            done(Outcome(error=exc))
            return lambda: None
        holder.append(ticket)
        self._tickets.add(ticket)
        return lambda: self._long.cancel(ticket)

    def close(self) -> None:
        """Forget waiting requests, cancel this session's long job and drop outcomes still to come."""
        with self._lock:
            self.closed = True
            self._waiting.clear()
        for ticket in list(self._tickets):
            self._long.cancel(ticket)
