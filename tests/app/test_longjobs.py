"""The server's queue of long jobs (app.jobs.long): one per session, bounded, first come first served, positions."""

from __future__ import annotations

import multiprocessing
import threading
from functools import partial

import pytest

from app.jobs import Cancelled, LongJobQueue, Outcome, QueueFull, in_process


class Gate:
    """A long job that runs until released, recording when it started (an event, not a sleep)."""

    def __init__(self) -> None:
        self.started, self.release = threading.Event(), threading.Event()

    def __call__(self, cancel: threading.Event):
        self.started.set()
        while not self.release.wait(0.01):
            if cancel.is_set():
                raise RuntimeError("cancelled")
        return "done"


def _done():
    box: dict = {"event": threading.Event()}

    def done(outcome: Outcome) -> None:
        box["outcome"] = outcome
        box["event"].set()

    return box, done


def test_one_at_a_time_first_come_first_served_with_positions():
    q = LongJobQueue(workers=1, max_waiting=3)
    jobs = [Gate() for _ in range(3)]
    places: dict[int, list[int]] = {k: [] for k in range(3)}
    boxes = []
    for k, job in enumerate(jobs):
        box, done = _done()
        boxes.append(box)
        q.submit(owner=object(), fn=job, done=done, on_position=places[k].append)
    assert jobs[0].started.wait(10)
    assert not jobs[1].started.is_set() and q.load == (1, 2)
    assert places[1][-1] == 1 and places[2][-1] == 2  # "1 job ahead", "2 jobs ahead"
    jobs[0].release.set()
    assert jobs[1].started.wait(10) and places[2][-1] == 1  # moved up
    jobs[1].release.set()
    jobs[2].release.set()
    for box in boxes:
        assert box["event"].wait(10) and box["outcome"].value == "done"


def test_a_session_has_at_most_one_long_job_and_the_queue_is_bounded():
    q = LongJobQueue(workers=1, max_waiting=1)
    me, running, waiting = object(), Gate(), Gate()
    q.submit(owner=me, fn=running, done=lambda o: None, on_position=lambda k: None)
    assert running.started.wait(10)
    with pytest.raises(QueueFull, match="you already have a long computation"):
        q.submit(owner=me, fn=Gate(), done=lambda o: None, on_position=lambda k: None)
    q.submit(owner=object(), fn=waiting, done=lambda o: None, on_position=lambda k: None)
    with pytest.raises(QueueFull, match="the server is busy: 1 long computations are waiting"):
        q.submit(owner=object(), fn=Gate(), done=lambda o: None, on_position=lambda k: None)
    running.release.set()
    waiting.release.set()


def test_cancel_drops_a_waiting_job_and_stops_a_running_one():
    q = LongJobQueue(workers=1, max_waiting=4)
    first, second = Gate(), Gate()
    box1, done1 = _done()
    box2, done2 = _done()
    t1 = q.submit(owner=object(), fn=first, done=done1, on_position=lambda k: None)
    t2 = q.submit(owner=object(), fn=second, done=done2, on_position=lambda k: None)
    assert first.started.wait(10)
    assert q.cancel(t2) is True and q.load == (1, 0)  # dropped before it ran: never started
    assert q.cancel(t1) is False  # running: asked to stop
    assert box1["event"].wait(10) and isinstance(box1["outcome"].error, RuntimeError)
    assert not second.started.is_set()
    assert box2["event"].is_set() and isinstance(box2["outcome"].error, Cancelled)  # it ended, as cancelled


def _counting(n: int, *, progress) -> int:
    """A picklable long job: reports n steps of progress, returns n (or runs forever when n < 0)."""
    k = 0
    while n < 0 or k < n:
        k += 1
        progress(k / abs(n) if n > 0 else 0.5)
    return k


def _failing(*, progress) -> None:
    raise ValueError("horizon must be at most 2000, got 3000")


def test_in_process_returns_the_value_and_relays_progress():
    seen: list[float] = []
    assert in_process(partial(_counting, 200), seen.append, threading.Event()) == 200
    assert seen[-1] == 1.0 and 50 <= len(seen) <= 101 and seen == sorted(seen)  # 1 % steps, in order


def test_in_process_raises_the_jobs_error_with_its_message():
    with pytest.raises(ValueError, match="horizon must be at most 2000, got 3000"):
        in_process(_failing, lambda f: None, threading.Event())


def test_cancelling_stops_the_child_process():
    cancel, children = threading.Event(), []

    def progress(fraction: float) -> None:  # the job reports; cancel once it is surely running
        children.extend(multiprocessing.active_children())
        cancel.set()

    with pytest.raises(Cancelled):
        in_process(partial(_counting, -1), progress, cancel)
    assert children and not any(c.is_alive() for c in children)


def test_the_servers_queue_runs_long_jobs_in_processes():
    from app.app import LONG_JOBS

    assert LONG_JOBS.processes
