"""The server's long jobs (ν-sweep points, recommendations, worst-case tables): one queue for every session.

Long jobs take seconds to minutes of one core each. They run one at a time (``workers``, default 1), first come
first served, at a lower CPU priority than the slider runs and the event loop, so that a classroom's long jobs never
hold up its slider updates and the machine keeps a core for them. With ``processes=True`` (the server's queue) each
job runs in a child process (:func:`in_process`): a thread's CPU priority does not extend to the interpreter lock,
and a long job's Python between its numba kernels, holding that lock, would slow every callback of the event loop
(:ref:`performance-threads`); a child's memory goes back to the system when it ends, and cancelling it ends it at
once.
The rules, as data that a test can check without a browser:

* each session has at most one long job, waiting or running (a second one is refused with a message);
* at most ``max_waiting`` jobs wait (then a new one is refused: "the server is busy, try again");
* a waiting job knows its place — ``on_position(k)`` is called with the number of jobs ahead of it (running ones
  included) whenever that number changes;
* a job can be cancelled while it waits (it is dropped) or while it runs (its ``cancel`` event is set; the job's
  progress callback raises at its next report);
* with one server process per core, "one at a time" holds for the whole server, not per process: a job starts only
  once it holds the server's slot (:func:`machine_slot`), so that heavy sessions on one process do not take every
  core from the students of another; a job waiting for a job of another process counts that one as ahead of it.

Each session reaches the queue through its :class:`app.jobs.threads.Jobs` (``submit_long``) and shows a job's progress,
place and outcome through a :class:`LongTask`.
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import multiprocessing
import os
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from functools import partial
from multiprocessing.connection import wait
from typing import Any

from .base import LONG_NICE, Cancelled, Outcome, QueueFull, call, in_steps, lower_priority

__all__ = ["SLOT_ENV", "LongJobQueue", "LongTask", "Ticket", "in_process", "machine_slot", "ping"]

log = logging.getLogger(__name__)

SLOT_ENV = "ISL_LONG_JOBS_LOCK"  #: the lock file of the server's one long-job slot (:func:`machine_slot`)


@dataclass(eq=False)
class Ticket:
    """One long job: its owner (a session), the work, and the callbacks (called from the queue's threads)."""

    owner: object
    fn: Callable[[threading.Event], Any]
    done: Callable[[Outcome], None]
    on_position: Callable[[int], None]
    cancel: threading.Event = field(default_factory=threading.Event)


class LongJobQueue:
    """A first-come-first-served queue of long jobs on ``workers`` low-priority threads (module docstring)."""

    def __init__(self, workers: int = 1, max_waiting: int = 8, nice: int = LONG_NICE, processes: bool = False) -> None:
        self.max_waiting = max_waiting
        self.processes = processes  #: run each job's computation in a child process (:func:`in_process`)
        self.workers, self.nice = workers, nice
        self._start()

    def _start(self) -> None:
        """The queue's state and threads, in this process (again in a forked server worker: threads do not survive
        a fork, and a queue inherited without them would never run a job)."""
        self._pid = os.getpid()
        self._waiting: list[Ticket] = []
        self._running: list[Ticket] = []
        self._elsewhere = 0  # 1 while a job waits for the machine's slot (another process's long job holds it)
        self._cv = threading.Condition()
        self._threads = [
            threading.Thread(target=self._work, args=(lower_priority(self.nice),), daemon=True, name=f"isl-long-{k}")
            for k in range(self.workers)
        ]
        for t in self._threads:
            t.start()

    def submit(
        self,
        owner: object,
        fn: Callable[[threading.Event], Any],
        done: Callable[[Outcome], None],
        on_position: Callable[[int], None],
    ) -> Ticket:
        """Queue ``fn(cancel_event)`` for ``owner``; ``done(outcome)`` when it ends. ``QueueFull`` if it may not."""
        ticket = Ticket(owner, fn, done, on_position)
        if self._pid != os.getpid():
            self._start()
        with self._cv:
            if any(t.owner is owner for t in (*self._waiting, *self._running)):
                raise QueueFull("you already have a long computation waiting or running; wait for it or cancel it")
            if len(self._waiting) >= self.max_waiting:
                raise QueueFull(
                    f"the server is busy: {len(self._waiting)} long computations are waiting already; "
                    "try again in a minute"
                )
            self._waiting.append(ticket)
            self._cv.notify()
        self._report()
        return ticket

    def cancel(self, ticket: Ticket) -> bool:
        """Drop ``ticket`` if it waits (True; it ends at once as :class:`Cancelled`), else ask it to stop (its
        progress callback raises at its next report)."""
        ticket.cancel.set()
        with self._cv:
            waiting = ticket in self._waiting
            if waiting:
                self._waiting.remove(ticket)
        if waiting:
            self._report()
            ticket.done(Outcome(error=Cancelled()))
        return waiting

    def positions(self) -> dict[int, int]:
        """``{id(ticket): jobs ahead}`` of the waiting tickets (for tests and logs)."""
        with self._cv:
            return {id(t): self._ahead() + k for k, t in enumerate(self._waiting)}

    @property
    def load(self) -> tuple[int, int]:
        """``(running, waiting)`` jobs."""
        with self._cv:
            return len(self._running), len(self._waiting)

    def _report(self) -> None:
        with self._cv:
            places = [(t, self._ahead() + k) for k, t in enumerate(self._waiting)]
        for ticket, ahead in places:
            try:
                ticket.on_position(ahead)
            except Exception:  # a closed session's callback must not stop the queue
                log.debug("position report failed", exc_info=True)

    def _ahead(self) -> int:
        return len(self._running) + self._elsewhere

    def _waits_elsewhere(self) -> None:
        with self._cv:
            self._elsewhere = 1
        self._report()

    def _work(self, initializer: Callable[[], None]) -> None:
        initializer()
        while True:
            with self._cv:
                while not self._waiting:
                    self._cv.wait()
            with machine_slot(on_wait=self._waits_elsewhere):  # another process of the server may run one
                with self._cv:
                    self._elsewhere = 0
                    if not self._waiting:  # cancelled while it waited for the slot
                        continue
                    ticket = self._waiting.pop(0)
                    self._running.append(ticket)
                self._report()
                outcome = call(partial(ticket.fn, ticket.cancel))
                with self._cv:
                    self._running.remove(ticket)
            self._report()
            try:
                ticket.done(outcome)
            except Exception:
                log.exception("delivering a long job's outcome failed")
            # while this thread waits for the next job, it must not hold the last one: its ticket holds the session
            # (its page, state and jobs) and the outcome its result, which would outlive the session's end
            del ticket, outcome


@contextlib.contextmanager
def machine_slot(path: str | None = None, on_wait: Callable[[], None] | None = None) -> Iterator[None]:
    """Hold the server's one long-job slot, shared by all its processes: an exclusive ``flock`` on the file named by
    ``ISL_LONG_JOBS_LOCK`` (:func:`app.serving.serve.serve` creates it before the workers fork), waited for in the
    kernel (``on_wait()`` first, if another process holds it). The kernel releases it when its holder's process ends,
    however it ends: a killed worker cannot keep it. Without the variable (one process, tests) the queue's own thread
    is the only limit."""
    path = path if path is not None else os.environ.get(SLOT_ENV)
    if not path:
        yield
        return
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o600)
    except OSError:  # the file went away (its directory cleaned): this process's queue alone limits its jobs
        log.warning("long jobs: cannot open the server's slot %s; this process runs its own one at a time", path)
        yield
        return
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            if on_wait is not None:
                on_wait()
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


#: modules the child processes' parent (a fork server) imports once, so that a job starts in milliseconds
PRELOAD = ["isl_core", "app.sweeps", "app.extras"]
_CONTEXT: list = []
_CANCEL_CHECK_S = 0.2  # a cancelled job's child is stopped within this time


def _context():
    """The fork-server context: children fork from a small single-threaded server process, never from the web
    server itself (forking a process with running threads can copy a lock held by another thread)."""
    if not _CONTEXT:
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(PRELOAD)
        _CONTEXT.append(ctx)
    return _CONTEXT[0]


def _child(fn: Callable[..., Any], conn, nice: int) -> None:
    """In the child: ``fn(progress=…)``, its progress (in 1 % steps) and its value or error sent back on ``conn``."""
    os.nice(nice)
    try:
        conn.send(("value", fn(progress=in_steps(lambda fraction: conn.send(("progress", float(fraction)))))))
    except Exception as exc:  # every failure goes back to the session as a message
        logging.getLogger(__name__).debug("long job failed", exc_info=True)
        try:
            conn.send(("error", exc))
        except Exception:  # noqa: BLE001 — an exception that does not pickle goes back as its text
            conn.send(("error", RuntimeError(f"{type(exc).__name__}: {exc}")))
    finally:
        conn.close()


def ping(*, progress: Callable[[float], None]) -> str:
    """The smallest long job (``in_process(ping, …)`` at start-up starts the fork server and checks it works)."""
    progress(1.0)
    return "ok"


def in_process(
    fn: Callable[..., Any], progress: Callable[[float], None], cancel: threading.Event, nice: int = LONG_NICE
) -> Any:
    """``fn(progress=…)`` computed in a child process at CPU priority ``nice``; returns its value or raises its
    error. ``progress(fraction)`` is called here (on the calling thread) as the child reports; if ``cancel`` is set,
    or ``progress`` raises, the child is stopped at once and :class:`Cancelled` (or that error) is raised.
    ``fn`` and its result must pickle (a ``functools.partial`` of a module-level function over plain values)."""
    ctx = _context()
    here, there = ctx.Pipe(duplex=False)
    child = ctx.Process(target=_child, args=(fn, there, nice), daemon=True, name="isl-long-job")
    child.start()
    there.close()
    try:
        while True:
            if cancel.is_set():
                raise Cancelled()
            if not wait([here, child.sentinel], timeout=_CANCEL_CHECK_S):
                continue
            try:
                kind, value = here.recv()
            except EOFError:
                child.join()
                raise RuntimeError(
                    f"the computation's process ended without an answer (exit code {child.exitcode}"
                    + (", perhaps out of memory)" if child.exitcode == -9 else ")")
                ) from None
            if kind == "progress":
                progress(value)
            elif kind == "value":
                return value
            else:
                raise value
    finally:
        here.close()
        if child.is_alive():
            child.terminate()
        child.join()


class LongTask:
    """One kind of long job of a session (the ν-sweep's, the worst case's): start, progress, place in the queue,
    cancel, and the outcome — written to three of ``state``'s parameters (``busy``, ``progress``, ``note``).

    ``state`` (a session or one of its rooms, :class:`app.state.Room`) provides ``jobs``
    (:class:`app.jobs.threads.Jobs`), ``later(fn)`` and ``describe(error)`` for failures.
    """

    def __init__(self, state, *, busy: str, progress: str, note: str) -> None:
        self.state, self.busy, self.progress, self.note = state, busy, progress, note
        self._cancel: Callable[[], None] | None = None
        self._token = object()

    def start(self, fn: Callable[..., Any], apply: Callable[[Outcome], None], note: str) -> None:
        """Run ``fn(progress=…)`` as the session's long job; ``apply(outcome)`` on success (on the session's loop)."""
        token = self._token = object()
        self.state.param.update(**{self.busy: True, self.progress: 0.0, self.note: note})
        show = in_steps(lambda fraction: self.state.later(lambda: self._set(token, progress=min(fraction, 1.0))))

        def run(cancel: threading.Event):
            def progress(fraction: float) -> None:  # on the worker thread
                if cancel.is_set():
                    raise Cancelled()
                show(fraction)

            if self.state.jobs.long_in_process:
                return in_process(fn, progress, cancel)
            return fn(progress=progress)

        def waiting(ahead: int) -> None:
            what = "another long computation is" if ahead == 1 else f"{ahead} long computations are"
            self._set(
                token,
                note=f"Waiting: {what} ahead of yours (the server runs them one at a time). {note}" if ahead else note,
            )

        self._cancel = self.state.jobs.submit_long(run, lambda outcome: self._finish(token, apply, outcome), waiting)

    def cancel(self) -> None:
        """Stop the job: dropped if it still waits; if it runs, its child process is ended at once (on a thread: at its
        next progress report)."""
        if self._cancel is not None:
            self._cancel()

    def _set(self, token: object, *, progress: float | None = None, note: str | None = None) -> None:
        if token is not self._token or not getattr(self.state, self.busy):
            return
        if progress is not None:
            setattr(self.state, self.progress, progress)
        if note is not None:
            setattr(self.state, self.note, note)

    def _finish(self, token: object, apply: Callable[[Outcome], None], outcome: Outcome) -> None:
        if token is not self._token:
            return
        self._cancel = None
        self.state.param.update(**{self.busy: False, self.progress: 0.0})
        err = outcome.error
        if isinstance(err, Cancelled):
            setattr(self.state, self.note, "Cancelled.")
        elif isinstance(err, QueueFull):
            setattr(self.state, self.note, f"Not started: {err}.")
        elif err is not None:
            setattr(self.state, self.note, f"Failed: {self.state.describe(err)}.")
        else:
            apply(outcome)
