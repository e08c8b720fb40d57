"""One server process per core (app.serving.workers): each page built once, wherever its websocket lands; a signal to
the server ends every process and frees the port; long jobs hold one slot for the whole server."""

from __future__ import annotations

import asyncio
import logging
import multiprocessing
import os
import re
import select
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from _serving import fixture_app, run, served, session_client
from bokeh.util.token import get_session_id

from app.jobs.long import SLOT_ENV, LongJobQueue
from app.serving import workers

BUILT = re.compile(  # app.serving.offloop's line for each page it builds
    r"isl page: built for session (\S+) in process (\d+)"
)
PAGES = 8
ROOT = Path(__file__).resolve().parents[2]


def test_usable_cores_follow_the_cgroup_quota(tmp_path):
    cpu_max = tmp_path / "cpu.max"
    cpu_max.write_text("max 100000\n")
    affinity = len(os.sched_getaffinity(0))
    assert workers.usable_cores(cpu_max) == affinity
    cpu_max.write_text("50000 100000\n")  # half a core: still one process
    assert workers.usable_cores(cpu_max) == 1
    assert workers.usable_cores(tmp_path / "none") == affinity


def listening(pid: int, port: int) -> set[str]:
    """The sockets (by inode) listening on ``port`` that process ``pid`` holds."""
    inodes = set()
    for table in ("tcp", "tcp6"):
        for line in Path(f"/proc/net/{table}").read_text().splitlines()[1:]:
            fields = line.split()
            if int(fields[1].rsplit(":", 1)[1], 16) == port and fields[3] == "0A":  # 0A: LISTEN
                inodes.add(fields[9])
    held = {os.readlink(f"/proc/{pid}/fd/{fd}") for fd in os.listdir(f"/proc/{pid}/fd")}
    return {inode for inode in inodes if f"socket:[{inode}]" in held}


def children(pid: int) -> list[int]:
    return [int(p) for p in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]


class Stopper:
    """Signals a running server and waits, on each of its processes' exit (a pidfd per process: readable once that
    process has ended, a child of the server or not), for all of them to end; then the port must be free."""

    def __init__(self, proc, url: str) -> None:
        self.proc, self.port = proc, int(url.rsplit(":", 1)[1])
        pids = set(session_client.descendants(proc.pid))  # the two workers and their long jobs' fork servers
        assert len(pids) >= 2
        self.exits = [os.pidfd_open(pid) for pid in pids]

    def stop(self, signum: int) -> int:
        try:
            os.kill(self.proc.pid, signum)
            code = self.proc.wait(workers.GRACE_S + 10)
            pending = set(self.exits)
            while pending:
                ready, _, _ = select.select(list(pending), [], [], workers.GRACE_S + 10)
                assert ready, f"still running after the grace period: {session_client.descendants(self.proc.pid)}"
                pending -= set(ready)
        finally:
            for fd in self.exits:
                os.close(fd)
        with socket.socket() as s:  # a new server can listen on the port (SO_REUSEADDR, as tornado's: closed
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # connections may linger in TIME_WAIT, a
            s.bind(("127.0.0.1", self.port))  # listener may not)
            s.listen()
        return code


def test_pages_built_once_where_their_websocket_lands_and_sigterm_ends_every_process(tmp_path):
    """Pages loaded as a browser loads them (the HTML, then a websocket with the page's token) from two processes:
    the HTML answers build nothing, and each page is built exactly once, by the process holding its session. Then
    SIGTERM (systemd, Kubernetes, a benchmark), with those pages still open, ends every process of the server within
    the grace period and frees the port (SIGINT: the long jobs' test below)."""
    script = fixture_app(tmp_path)
    with served(tmp_path, "--num-procs", "2", "--stats-interval", "0", script=script) as (url, proc, log):
        stopper = Stopper(proc, url)
        # each worker listens on a socket of its own (SO_REUSEPORT: the kernel spreads connections evenly); the
        # parent only holds the port
        own = [listening(pid, stopper.port) for pid in children(proc.pid)]
        assert not listening(proc.pid, stopper.port)
        assert len(own) == 2 and all(len(s) == 1 for s in own) and own[0] != own[1], own
        # a second server on the same port fails as with one process, instead of joining the first one's group
        second = session_client.start_server(
            stopper.port, tmp_path / "second.log", ["--num-procs", "2", "--stats-interval", "0"], script=script
        )
        assert second.wait(120) == 1
        assert "already in use" in (tmp_path / "second.log").read_text()
        assert [listening(pid, stopper.port) for pid in children(proc.pid)] == own  # the first serves on

        async def scenario() -> tuple[list[str], int]:
            tokens = [await session_client.page_token(url) for _ in range(PAGES)]
            assert not BUILT.findall(log.read_text())  # the HTML answers built nothing
            clients = [await session_client.BokehClient.connect(url, token=t) for t in tokens]
            try:
                assert all([await c.widgets(60) for c in clients])
                return tokens, await asyncio.to_thread(stopper.stop, signal.SIGTERM)
            finally:
                await asyncio.gather(*(c.close() for c in clients))

        tokens, code = run(scenario())
        text = log.read_text()
    assert code == 0
    assert "serving with 2 worker processes" in text
    builds = BUILT.findall(text)
    sessions = [session for session, _ in builds]
    assert sorted(sessions) == sorted(get_session_id(t) for t in tokens), builds  # each page once, none twice


def _job(started: threading.Event, release: threading.Event, cancel: threading.Event) -> str:
    started.set()
    assert release.wait(60)
    return "done"


def test_long_jobs_of_two_processes_take_turns(tmp_path, monkeypatch):
    """Two queues on one lock file (as two server processes have): the second's job waits, told one is ahead of it,
    until the first's has ended."""
    monkeypatch.setenv(SLOT_ENV, str(tmp_path / "slot.lock"))
    first, second = LongJobQueue(), LongJobQueue()
    started = [threading.Event(), threading.Event()]
    release, finished = threading.Event(), threading.Event()
    places: list[int] = []
    told_ahead = threading.Event()

    def place(ahead: int) -> None:
        places.append(ahead)
        if ahead:
            told_ahead.set()

    first.submit("a", lambda c: _job(started[0], release, c), lambda o: None, lambda k: None)
    assert started[0].wait(30)
    second.submit("b", lambda c: _job(started[1], release, c), lambda o: finished.set(), place)
    assert told_ahead.wait(30) and not started[1].is_set()
    release.set()
    assert started[1].wait(30) and finished.wait(30)


def _submit_in_child(queue: LongJobQueue, out) -> None:
    done = threading.Event()
    queue.submit("child", lambda cancel: os.getpid(), lambda outcome: (out.send(outcome.value), done.set()), print)
    done.wait(30)


def test_a_queue_made_before_a_fork_runs_jobs_in_the_forked_process():
    """A server worker inherits the queue made before the fork without its thread: the queue starts it again there."""
    queue = LongJobQueue()
    here, there = multiprocessing.Pipe(duplex=False)
    child = multiprocessing.get_context("fork").Process(target=_submit_in_child, args=(queue, there))
    child.start()
    try:
        assert here.poll(60), "the job never ran in the forked process"
        assert here.recv() == child.pid
    finally:
        child.join(30)


WORST = "m=1&wc_alphas=[1.0]&wc_n_sigma=2&wc_horizon=20"  # the smallest worst-case table: a long job of seconds


def test_long_jobs_come_back_from_forked_processes(tmp_path):
    """A worst-case table asked for in two sessions of a server of two processes: both come back, one after the
    other (the server's one slot). Each process starts its own long-job queue and fork server after the fork; the
    queue inherited across it had no thread, and no worst case asked for in a forked process ever came back (this
    test failed so). Then SIGINT (Ctrl-C), pages open, ends every process and frees the port."""
    from bokeh.events import ButtonClick
    from bokeh.models import Markup

    def compute_button(doc):
        return next(m for m in doc.models if getattr(m, "label", None) == "Compute" and type(m).__name__ == "Button")

    def notes(doc) -> list[str]:
        return [m.text or "" for m in doc.models if isinstance(m, Markup)]

    with served(tmp_path, "--num-procs", "2", "--stats-interval", "0") as (url, proc, log):
        stopper = Stopper(proc, url)

        async def scenario() -> list[list[str]]:
            # opened at once, so that the processes' loops race for them (which one takes each is the kernel's call)
            clients = await asyncio.gather(*(session_client.open_page(url, WORST) for _ in range(2)))
            try:
                for client in clients:
                    tabs = next(m for m in client.doc.models if type(m).__name__ == "Tabs")
                    await client.change(tabs, active=2)  # the worst case's tab
                    assert await client.wait_until(
                        lambda c=client: any(getattr(m, "label", None) == "Compute" for m in c.doc.models), 120
                    )
                    await client.send_event(ButtonClick(compute_button(client.doc)))
                for client in clients:
                    assert await client.wait_until(
                        lambda c=client: any("Simulated in" in t or "Failed" in t for t in notes(c.doc)), 300
                    )
                answers = [notes(client.doc) for client in clients]
                assert await asyncio.to_thread(stopper.stop, signal.SIGINT) == 0  # Ctrl-C, pages open: all end
                return answers
            finally:
                await asyncio.gather(*(c.close() for c in clients))

        answers = run(scenario())
        assert len(BUILT.findall(log.read_text())) == 2  # built once each, in forked processes
    for texts in answers:
        assert any("Simulated in" in t for t in texts), [t for t in texts if "Failed" in t]


@pytest.mark.parametrize(
    ("query", "present"),
    [
        ("", False),
        ("?present=1", True),
        ("?present=yes&sigma=200", True),
        ("?present=0", False),
        ("?present=%00garbage", False),
        ("?present=1&present=off", False),
    ],
)
@pytest.mark.parametrize("path", ["/app", "/app/"])  # bokeh routes both to the page
def test_a_page_is_answered_from_one_of_two_start_up_pages(path, query, present):
    """Only presenter mode changes a page's HTML: any link maps to one of two pages built at start-up (a link cannot
    make a process keep another, with or without the trailing slash), read as the page reads its link (a repeated
    key: its last value)."""
    from tornado.httputil import HTTPHeaders, HTTPServerRequest, RequestStartLine

    from app.serving.pages import page_key

    request = HTTPServerRequest(
        start_line=RequestStartLine("GET", f"{path}{query}", "HTTP/1.1"), headers=HTTPHeaders({"Host": "x"})
    )
    assert page_key(request) == ("/app", present)


REFORK = """
import os, sys
from app.serving.workers import Supervisor
Supervisor(1, max_restarts=2).run()  # returns in each worker
with open(sys.argv[1], "a") as f:
    f.write(f"{os.getpid()}\\n")
os._exit(0)  # unasked: the server did not stop
"""


def test_a_worker_that_ends_unasked_is_forked_again(tmp_path):
    """A worker ending with status 0 while the server was not stopping leaves the class one process short: it is
    forked again (counted with the restarts; past them the server stops with status 1)."""
    ran = tmp_path / "workers"
    done = subprocess.run(
        [sys.executable, "-c", REFORK, str(ran)], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 1, done.stderr
    assert len(set(ran.read_text().split())) == 3  # the first worker and its two restarts
    assert done.stderr.count("ended with status 0: starting it again") == 2, done.stderr
    assert "workers died 3 times" in done.stderr


def test_the_signal_handlers_only_pass_signals_on_and_the_wait_loop_logs(caplog):
    """No logging inside a signal handler (its locks may be held by the code it interrupted): SIGTERM and the grace
    period's timer only signal the workers and set flags; the parent's wait loop logs what they did."""
    supervisor = workers.Supervisor(1, grace_s=3600.0)
    child = subprocess.Popen(["sleep", "60"])  # a worker that does not stop by itself
    supervisor.children[child.pid] = 0
    previous = signal.getsignal(signal.SIGALRM)
    try:
        with caplog.at_level(logging.DEBUG, logger="isl.serve"):
            supervisor._on_signal(signal.SIGTERM, None)
            supervisor._kill_remaining(signal.SIGALRM, None)
            assert not caplog.records  # the handlers logged nothing
            assert child.wait(30) in (-signal.SIGTERM, -signal.SIGKILL)  # the worker was signalled
            supervisor._report()
        messages = [record.getMessage() for record in caplog.records]
        assert messages == [
            f"stopping 1 worker process(es) (signal {int(signal.SIGTERM)})",
            f"worker {child.pid} did not stop within 3600 s: killed",
        ]
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
        child.kill()


@pytest.mark.parametrize("before", [None, "/elsewhere/slot.lock"])
def test_the_long_job_slot_gives_its_variable_back_on_close(tmp_path, monkeypatch, before):
    """Servers started one after another in one process (the tests) must not inherit a removed lock file's name."""
    if before is None:
        monkeypatch.delenv(SLOT_ENV, raising=False)
    else:
        monkeypatch.setenv(SLOT_ENV, before)
    slot = workers.LongJobSlot(str(tmp_path))
    path = slot.path
    assert path is not None and os.environ[SLOT_ENV] == path and Path(path).exists()
    slot.close()
    assert not Path(path).exists()
    assert os.environ.get(SLOT_ENV) == before
