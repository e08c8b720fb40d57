"""One server process per core: how many, how they are forked, and how they all stop.

Bokeh forks its worker processes through tornado (``HTTPServer.start(n)`` → ``tornado.process.fork_processes``):
the parent binds the port, forks ``n`` children that all accept on that one socket, and then only waits for them,
restarting any that dies. Two things about that parent do not suit a server that systemd, Kubernetes or a benchmark
stops with a signal:

* SIGTERM ends the parent alone (Python's default action); the children, which never received it, go on answering
  on the port — orphans that hold it until each is signalled by hand;
* a child that ends with an error status is forked again, a child that failed its start-up included.

:func:`supervise` replaces ``fork_processes`` for the serving process (:func:`install`); it forks the same way and
gives each child tornado's task id, and in the parent:

* SIGTERM or SIGINT is passed on to every worker; the parent then waits for them (each stops its server and exits)
  and ends with them. A worker still alive :data:`GRACE_S` seconds later is killed, so the port is free within the
  grace period of a container runtime (Kubernetes: 30 s, ``docker stop``: 10 s);
* a worker that fails its start-up (:data:`STARTUP_FAILED`, the app script failed its warm-up) stops the whole
  server with exit code 1, as one process would; a worker that ends otherwise (out of memory, a crash, a signal
  sent to it alone, even with status 0) is forked again — never during a shutdown. The handlers only set flags and
  send signals; the parent's wait loop logs what they did.

Each worker also asks the kernel for SIGTERM should its parent die (``PR_SET_PDEATHSIG``): a parent killed with
SIGKILL, which it cannot pass on, leaves no worker behind.

:func:`usable_cores` is what "one per core" means: the cores this process may run on, capped by its cgroup's CPU
quota (a container limited to 2 CPUs on a 64-core node runs 2 processes, not 64).
"""

from __future__ import annotations

import contextlib
import ctypes
import gc
import logging
import math
import os
import random
import signal
import socket
import sys
from pathlib import Path

log = logging.getLogger("isl.serve")

GRACE_S = 8.0  #: seconds a worker has to stop after SIGTERM before it is killed (docker stop waits 10 s)
STARTUP_FAILED = 3  #: a worker's exit status when the app failed its warm-up: the server stops
MAX_RESTARTS = 100  #: as tornado: a worker dying over and over ends the server
_PR_SET_PDEATHSIG = 1
_CGROUP_CPU_MAX = Path("/sys/fs/cgroup/cpu.max")


def usable_cores(cpu_max: Path = _CGROUP_CPU_MAX) -> int:
    """The cores this process may use: its CPU affinity, capped by a cgroup v2 CPU quota (``cpu.max``), at least 1."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    try:
        quota, period = cpu_max.read_text().split()[:2]
        if quota != "max":
            cores = min(cores, math.ceil(int(quota) / int(period)))
    except (OSError, ValueError):  # no cgroup v2 quota: the affinity alone
        pass
    return max(1, cores)


class Supervisor:
    """The parent's side: the workers by pid and task id, the signals it passes on, and why it stops."""

    def __init__(self, count: int, grace_s: float = GRACE_S, max_restarts: int = MAX_RESTARTS) -> None:
        self.count, self.grace_s, self.max_restarts = count, grace_s, max_restarts
        self.children: dict[int, int] = {}  # pid → task id
        self.stopping = False
        self.signalled: int | None = None  # a signal the handler passed on, not yet logged
        self.killed: list[int] = []  # workers killed at the grace period's end, not yet logged
        self.status = 0
        self.pid = os.getpid()

    def start_child(self, task: int) -> int | None:
        """Fork worker ``task``; its task id in the child, None in the parent."""
        pid = os.fork()
        if pid == 0:
            _become_worker(task, self.pid)
            return task
        self.children[pid] = task
        return None

    def stop(self, signum: int = signal.SIGTERM, status: int | None = None) -> None:
        """Pass ``signum`` on to every worker and arm the grace period's end (idempotent).

        Called from the signal handler: it only sets flags, sends signals and arms a timer — no logging, whose locks
        the interrupted code may hold (what happened is logged by :meth:`run`'s loop, outside any handler)."""
        if status is not None and self.status == 0:
            self.status = status
        if self.stopping:
            return
        self.stopping, self.signalled = True, signum
        for pid in list(self.children):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGTERM)
        signal.signal(signal.SIGALRM, self._kill_remaining)
        signal.setitimer(signal.ITIMER_REAL, self.grace_s)

    def _kill_remaining(self, signum, frame) -> None:  # the grace period's timer (a signal handler: no logging)
        for pid in list(self.children):
            self.killed.append(pid)
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)

    def _on_signal(self, signum, frame) -> None:
        if os.getpid() != self.pid:  # a worker between fork and its own handlers: stop as the default would
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)
            return
        self.stop(signum)

    def _report(self) -> None:
        """Log what the signal handlers did since the last call (from the wait loop, never from a handler)."""
        if self.signalled is not None:
            log.info("stopping %d worker process(es) (signal %d)", len(self.children), self.signalled)
            self.signalled = None
        while self.killed:
            log.warning("worker %d did not stop within %.0f s: killed", self.killed.pop(0), self.grace_s)

    def run(self) -> int:
        """Fork the workers and wait for them; returns the task id in a worker, exits with the status in the parent."""
        for sig in (signal.SIGTERM, signal.SIGINT):
            signal.signal(sig, self._on_signal)
        # What exists now (the kernels, the imported libraries) is shared by the workers until one writes to it; a
        # garbage collection writes to every object it walks, so they are moved out of its reach first (Python's
        # advice for servers that fork). The parent's own collection at exit then takes milliseconds, not seconds.
        gc.freeze()
        for task in range(self.count):
            if self.stopping:  # signalled while forking: fork no more
                break
            if self.start_child(task) is not None:
                return task
        log.info("serving with %d worker processes (parent pid %d)", self.count, self.pid)
        restarts = 0
        while self.children:
            self._report()
            pid, wait_status = os.wait()  # a signal handler runs in here; the wait resumes after it (PEP 475)
            self._report()
            if pid not in self.children:
                continue
            task = self.children.pop(pid)
            code = os.waitstatus_to_exitcode(wait_status)
            if self.stopping:
                continue
            if code == STARTUP_FAILED:
                log.error("worker %d failed its start-up: stopping the server", task)
                self.stop(status=1)
                continue
            restarts += 1
            if restarts > self.max_restarts:
                log.error("workers died %d times: stopping the server", restarts)
                self.stop(status=1)
                continue
            # a worker ends only when the server stops: one that ended otherwise — with an error, killed, or with
            # status 0 after a signal of its own — leaves its share of the class to the others; it is forked again
            log.warning("worker %d (pid %d) ended with status %d: starting it again", task, pid, code)
            if self.start_child(task) is not None:
                return task
        self._report()
        signal.setitimer(signal.ITIMER_REAL, 0)
        sys.exit(self.status)


def _become_worker(task: int, parent: int) -> None:
    """In a freshly forked worker: tornado's task id, its own random seed, the default signal actions (the server
    sets its own), and SIGTERM should the parent die."""
    import tornado.process

    tornado.process._task_id = task  # type: ignore[assignment]  # what tornado.process.task_id() answers
    random.seed()
    signal.setitimer(signal.ITIMER_REAL, 0)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: the parent's SIGTERM still reaches every worker
        log.debug("no parent-death signal for worker %d", task)
    if os.getppid() != parent:  # the parent died before the request above
        os._exit(0)


def supervise(num_processes: int | None, max_restarts: int | None = None) -> int:
    """``tornado.process.fork_processes`` with the signal handling above (same signature and return value); each
    worker then listens on sockets of its own (:func:`bind_reserved`)."""
    import tornado.process

    if tornado.process._task_id is not None:
        raise RuntimeError("the server's workers are forked already")
    count = num_processes if num_processes and num_processes > 0 else usable_cores()
    task = Supervisor(count, max_restarts=MAX_RESTARTS if max_restarts is None else max_restarts).run()
    listen_own()
    return task


#: the port's sockets, the very list bokeh adds to its server after the fork: bound in the parent, which never
#: accepts (not listening: it only holds the port), replaced in each worker by listening ones of its own
SOCKETS: list[socket.socket] = []
LISTEN_BACKLOG = 128  #: each worker's queue of connections not yet accepted (tornado's default)


def _reusing(family: int, kind: int, proto: int, address: tuple, listen: bool) -> socket.socket:
    """A socket bound to ``address`` in its ``SO_REUSEPORT`` group; listening if ``listen``."""
    sock = socket.socket(family, kind, proto)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
    if family == socket.AF_INET6:
        sock.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
    sock.setblocking(False)
    sock.bind(address)
    if listen:
        sock.listen(LISTEN_BACKLOG)
    return sock


def bind_reserved(address: str | None, port: int) -> tuple[list[socket.socket], int]:
    """``bokeh.server.util.bind_sockets`` for a server of several processes: the port bound with ``SO_REUSEPORT``
    by sockets that do not listen. Each worker listens on its own (:func:`listen_own`), and the kernel hands each new
    connection to one of them by a hash of its addresses — an even spread, where one shared socket went to whichever
    process woke first (8 and 48 pages of a class).

    tornado binds first, as for one process, without ``SO_REUSEPORT``: it resolves the address and fails if anything
    listens on the port — another server's workers included, which a socket in their group would silently have
    joined (a second server started on the same port then took half the first one's connections)."""
    from tornado.netutil import bind_sockets

    probes = bind_sockets(port or 0, address or None)
    found = [(s.family, s.type, s.proto, s.getsockname()) for s in probes]
    for sock in probes:
        sock.close()
    SOCKETS[:] = [_reusing(*where, listen=False) for where in found]
    return SOCKETS, SOCKETS[0].getsockname()[1]


def listen_own() -> None:
    """In a freshly forked worker: replace the parent's reserving sockets by listening ones of its own (in place, in
    the list bokeh holds), in the same ``SO_REUSEPORT`` group."""
    for k, sock in enumerate(SOCKETS):
        SOCKETS[k] = _reusing(sock.family, sock.type, sock.proto, sock.getsockname(), listen=True)
        sock.close()  # this process's copy; the parent keeps the port


def install() -> None:
    """Make tornado fork the server's workers through :func:`supervise` (bokeh calls ``fork_processes`` through the
    ``tornado.process`` module, so replacing it there is enough), and bokeh bind its port for them
    (:func:`bind_reserved`, which bokeh's server module imported by name)."""
    import bokeh.server.server
    import tornado.process

    tornado.process.fork_processes = supervise
    bokeh.server.server.bind_sockets = bind_reserved


class LongJobSlot:
    """The lock file of the server's one long-job slot (:func:`app.jobs.long.machine_slot`), named to every process
    by ``ISL_LONG_JOBS_LOCK``; the process that made it removes it on :meth:`close` (a worker's close does nothing),
    and gives the variable back the value it had before — a process that starts several servers one after another
    (the tests) must not hand a later one the name of a removed file."""

    def __init__(self, directory: str | None = None) -> None:
        import tempfile

        from app.jobs.long import SLOT_ENV

        self.owner, self.path = os.getpid(), None
        self._before = os.environ.get(SLOT_ENV)
        try:
            fd, self.path = tempfile.mkstemp(prefix="isl-long-jobs-", suffix=".lock", dir=directory)
            os.close(fd)
            os.environ[SLOT_ENV] = self.path
        except OSError as exc:  # no writable temporary directory: each process runs its own long jobs one at a time
            log.warning("long jobs: no lock file for the server's slot (%s); one at a time per process", exc)

    def close(self) -> None:
        from app.jobs.long import SLOT_ENV

        if self.path is None or os.getpid() != self.owner:
            return
        with contextlib.suppress(OSError):
            os.unlink(self.path)
        if os.environ.get(SLOT_ENV) == self.path:  # still ours: the value from before, or none
            if self._before is None:
                os.environ.pop(SLOT_ENV, None)
            else:
                os.environ[SLOT_ENV] = self._before
        self.path = None


def long_job_slot() -> LongJobSlot:
    """Make the server's long-job slot before the workers fork (see :class:`LongJobSlot`)."""
    return LongJobSlot()


def is_worker() -> bool:
    """This process is a forked worker (not the only server process, not the parent)."""
    import tornado.process

    return tornado.process.task_id() is not None
