"""The server's queue of long jobs (app.longjobs): one per session, bounded, first come first served, positions."""
from __future__ import annotations

import threading

import pytest

from app.jobs import Outcome
from app.longjobs import Cancelled, LongJobQueue, QueueFull


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
