"""One server process per core (app.serving.workers): each page built once, wherever its websocket lands; a signal to
the server ends every process and frees the port; long jobs hold one slot for the whole server."""

from __future__ import annotations

import asyncio
import multiprocessing
import os
import re
import select
import signal
import socket
import threading

import pytest
from _serving import fixture_app, run, served, session_client
from bokeh.util.token import get_session_id

from app.jobs.long import SLOT_ENV, LongJobQueue
from app.serving import workers

BUILT = re.compile(  # app.serving.offloop's line for each page it builds
    r"isl page: built for session (\S+) in process (\d+)"
)
PAGES = 8


def test_usable_cores_follow_the_cgroup_quota(tmp_path):
    cpu_max = tmp_path / "cpu.max"
    cpu_max.write_text("max 100000\n")
    affinity = len(os.sched_getaffinity(0))
    assert workers.usable_cores(cpu_max) == affinity
    cpu_max.write_text("50000 100000\n")  # half a core: still one process
    assert workers.usable_cores(cpu_max) == 1
    assert workers.usable_cores(tmp_path / "none") == affinity


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
