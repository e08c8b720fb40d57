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


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_pages_built_once_where_their_websocket_lands_and_a_signal_ends_every_process(tmp_path, signum):
    """Pages loaded as a browser loads them (the HTML, then a websocket with the page's token) from two processes:
    the HTML answers build nothing, and each page is built exactly once, by the process holding its session. Then
    SIGTERM (systemd, Kubernetes, a benchmark) or SIGINT to the server, with those pages still open, ends every
    process of it within the grace period and frees the port."""
    script = fixture_app(tmp_path)
    with served(tmp_path, "--num-procs", "2", "--stats-interval", "0", script=script) as (url, proc, log):
        procs = set(session_client.descendants(proc.pid))  # the two workers and their long jobs' fork servers
        assert len(procs) >= 2
        exits = {pid: os.pidfd_open(pid) for pid in procs}

        def stop() -> int:  # each pidfd becomes readable when its process has ended (a child of the server or not)
            os.kill(proc.pid, signum)
            code = proc.wait(workers.GRACE_S + 10)
            pending = set(exits.values())
            while pending:
                ready, _, _ = select.select(list(pending), [], [], workers.GRACE_S + 10)
                assert ready, f"still running after the grace period: {session_client.descendants(proc.pid)}"
                pending -= set(ready)
            return code

        async def scenario() -> tuple[list[str], int]:
            tokens = [await session_client.page_token(url) for _ in range(PAGES)]
            assert not BUILT.findall(log.read_text())  # the HTML answers built nothing
            clients = [await session_client.BokehClient.connect(url, token=t) for t in tokens]
            try:
                assert all([await c.widgets(60) for c in clients])
                return tokens, await asyncio.to_thread(stop)
            finally:
                await asyncio.gather(*(c.close() for c in clients))

        try:
            tokens, code = run(scenario())
        finally:
            for fd in exits.values():
                os.close(fd)
        text = log.read_text()
    assert code == 0
    assert "serving with 2 worker processes" in text
    builds = BUILT.findall(text)
    sessions = [session for session, _ in builds]
    assert sorted(sessions) == sorted(get_session_id(t) for t in tokens), builds  # each page once, none twice
    with socket.socket() as s:  # a new server can listen on the port (SO_REUSEADDR, as tornado's: closed
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # connections may linger in TIME_WAIT, a listener
        s.bind(("127.0.0.1", int(url.rsplit(":", 1)[1])))  # may not)
        s.listen()


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


def test_long_jobs_come_back_in_every_process(tmp_path):
    """A worst-case table asked for in a session of each of two processes: both come back (each process starts its
    own long-job queue and fork server after the fork; the queue inherited across it had no thread, and a worst case
    asked for in the second process never came back)."""
    from bokeh.events import ButtonClick
    from bokeh.models import Markup

    def compute_button(doc):
        return next(m for m in doc.models if getattr(m, "label", None) == "Compute" and type(m).__name__ == "Button")

    def notes(doc) -> list[str]:
        return [m.text or "" for m in doc.models if isinstance(m, Markup)]

    with served(tmp_path, "--num-procs", "2", "--stats-interval", "0") as (url, _, log):

        async def scenario() -> dict[str, list[str]]:
            clients: dict[str, session_client.BokehClient] = {}  # the first session of each process
            others = []
            try:
                for _ in range(12):  # the kernel spreads connections over the processes: until both have one
                    token = await session_client.page_token(url, query=WORST)
                    client = await session_client.BokehClient.connect(url, query=WORST, token=token)
                    process = dict(BUILT.findall(log.read_text()))[get_session_id(token)]
                    if process in clients:
                        others.append(client)
                    else:
                        clients[process] = client
                    if len(clients) == 2:
                        break
                assert len(clients) == 2, "12 pages all reached one process"
                for client in clients.values():
                    tabs = next(m for m in client.doc.models if type(m).__name__ == "Tabs")
                    await client.change(tabs, active=2)  # the worst case's tab
                    assert await client.wait_until(
                        lambda c=client: any(getattr(m, "label", None) == "Compute" for m in c.doc.models), 120
                    )
                    await client.send_event(ButtonClick(compute_button(client.doc)))
                for client in clients.values():
                    assert await client.wait_until(
                        lambda c=client: any("Simulated in" in t or "Failed" in t for t in notes(c.doc)), 300
                    )
                return {process: notes(client.doc) for process, client in clients.items()}
            finally:
                await asyncio.gather(*(c.close() for c in [*clients.values(), *others]))

        answers = run(scenario())
    for process, texts in answers.items():
        assert any("Simulated in" in t for t in texts), (process, [t for t in texts if "Failed" in t])
