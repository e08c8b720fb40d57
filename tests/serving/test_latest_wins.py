"""A session's runs, "latest wins" (app.jobs.Jobs), in the windows where a change races a run's end: whatever the
order of the run finishing, its outcome reaching the session's loop and the next change arriving, the newest change
is computed and its outcome applied as not superseded — so that it ends in a plot update.

The executor and the session's loop are driven by hand, one step at a time, so that each interleaving is taken
exactly (a served session reaches them from Panel's threads and the pools' threads)."""

from __future__ import annotations

from collections import deque
from concurrent.futures import Executor, Future

import pytest

from app.jobs import Jobs, Superseded


class StepExecutor(Executor):
    """Runs nothing until told: :meth:`finish` runs the oldest submitted function and completes its future."""

    def __init__(self) -> None:
        self.queued: deque[tuple[Future, object]] = deque()

    def submit(self, fn, /, *args, **kwargs):  # type: ignore[override]
        future: Future = Future()
        self.queued.append((future, lambda: fn(*args, **kwargs)))
        return future

    def finish(self) -> None:
        future, call = self.queued.popleft()
        future.set_result(call())  # app.jobs.call never raises: it returns an Outcome


class StepLoop:
    """The session's loop: what ``schedule`` hands it runs when :meth:`turn` is called."""

    def __init__(self) -> None:
        self.pending: deque = deque()

    def schedule(self, fn) -> None:
        self.pending.append(fn)

    def turn(self) -> None:
        while self.pending:
            self.pending.popleft()()


@pytest.fixture
def session():
    executor, loop, shown = StepExecutor(), StepLoop(), []
    jobs = Jobs({"run": executor}, schedule=loop.schedule)

    def change(sigma: float, fail: bool = False) -> None:
        def done(outcome, superseded: bool) -> None:
            shown.append((outcome.value, superseded, type(outcome.error).__name__ if outcome.error else None))
            if fail:
                raise RuntimeError("a view failed to update")

        jobs.submit("run", lambda progress=None: (progress and progress(0.5), sigma)[1], done, cancellable=True)

    return executor, loop, shown, change


@pytest.mark.parametrize(
    ("order", "expected"),
    [
        # the run has ended on its thread, its outcome not yet applied on the loop: shown as superseded, then the new
        ("finish, change, turn", [(20.0, True, None), (30.0, False, None)]),
        # the change arrives while the run computes: the run stops at its next report, never shown
        ("change, finish, turn", [(None, True, Superseded.__name__), (30.0, False, None)]),
        # the outcome is applied first: the change starts a run of its own
        ("finish, turn, change", [(20.0, False, None), (30.0, False, None)]),
    ],
)
def test_the_newest_change_is_computed_and_shown_whatever_the_interleaving(session, order, expected):
    executor, loop, shown, change = session
    change(20.0)
    for step in order.split(", "):
        {"finish": executor.finish, "turn": loop.turn, "change": lambda: change(30.0)}[step]()
    while executor.queued or loop.pending:
        if executor.queued:
            executor.finish()
        loop.turn()
    assert shown == expected


def test_changes_arriving_while_a_run_computes_keep_only_the_newest(session):
    executor, loop, shown, change = session
    change(20.0)
    for sigma in (21.0, 22.0, 23.0):
        change(sigma)
    executor.finish()  # 20's run stops at its report: a newer change waits
    loop.turn()
    executor.finish()
    loop.turn()
    assert shown == [(None, True, Superseded.__name__), (23.0, False, None)]


def test_a_view_that_fails_to_update_does_not_hold_the_next_change_back(session):
    executor, loop, shown, change = session
    change(20.0, fail=True)
    executor.finish()
    change(30.0)  # waits for 20's outcome, whose application raises
    with pytest.raises(RuntimeError):
        loop.turn()
    executor.finish()
    loop.turn()
    assert shown[-1] == (30.0, False, None)
