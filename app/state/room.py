"""A room of a session's state: one concern's inputs and outputs, composed into :class:`app.state.AppState`.

A room is a ``param.Parameterized`` whose inputs are named as the concern names them (``runs``, ``horizon``) and
whose :attr:`Room.KEYS` gives each input its *key*: its name in links, messages and refusals (``sc_runs``,
``sweep_horizon``) — one namespace for the whole page, so that a link or a refusal never needs to know which room
holds an input. An input's declaration is its only check: param refuses a bad value when it is assigned, and the
session's boundary (:meth:`app.state.AppState.set`, :meth:`app.state.AppState.set_inputs`) puts that refusal in
words beside the input.

A room reaches the rest of the session only through its host: the model's inputs, the session's jobs
(:meth:`later`, :meth:`describe`, :attr:`jobs`) and the refusals. A room with one long job of the server's queue
(the ν-sweep, the worst case, the data fit) is a :class:`LongJobRoom`.
"""

from __future__ import annotations

from typing import Any, ClassVar

import param

from ..jobs import LongTask

__all__ = ["LongJobRoom", "Room"]


class Room(param.Parameterized):
    """One concern of the session's state (module docstring); ``host`` is the :class:`app.state.AppState`."""

    #: key (the input's name in links and messages) → the room's parameter
    KEYS: ClassVar[dict[str, str]] = {}

    def __init__(self, host: Any, **params) -> None:
        super().__init__(**params)
        self._host = host

    @property
    def jobs(self):
        """The session's jobs (:class:`app.jobs.Jobs`)."""
        return self._host.jobs

    def later(self, fn) -> None:
        """Run ``fn()`` on the session's loop with its lock held (:meth:`app.state.AppState.later`)."""
        self._host.later(fn)

    def describe(self, error: BaseException) -> str:
        """A job's failure in words for the page."""
        return self._host.describe(error)

    def refused_among(self, keys) -> str:
        """Why a computation over inputs ``keys`` does not start (:meth:`app.state.AppState.refused_among`)."""
        return self._host.refused_among(keys)


class LongJobRoom(Room):
    """A room whose computation is one long job of the server's queue (:class:`app.jobs.LongTask`): whether it runs,
    how far it is, and its status line, declared once for every such room."""

    busy = param.Boolean(False, precedence=-1, doc="The room's long job is queued or running.")
    progress = param.Number(0.0, bounds=(0.0, 1.0), precedence=-1, doc="How far the long job is, 0 to 1.")
    note = param.String("", precedence=-1, doc="Status line of the room's long job.")

    def __init__(self, host: Any, **params) -> None:
        super().__init__(host, **params)
        self._task = LongTask(self, busy="busy", progress="progress", note="note")

    def cancel(self) -> None:
        """Stop the long job: dropped if it waits in the queue, else ended (:meth:`app.jobs.LongTask.cancel`)."""
        self._task.cancel()
