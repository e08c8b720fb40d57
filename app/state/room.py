"""A room of a session's state: one concern's inputs and outputs, composed into :class:`app.state.AppState`.

A room is a ``param.Parameterized`` whose inputs are named as the concern names them (``runs``, ``horizon``) and
whose :attr:`Room.KEYS` gives each input its *key*: its name in links, messages and refusals (``sc_runs``,
``sweep_horizon``) — one namespace for the whole page, so that a link or a refusal never needs to know which room
holds an input. Every value assigned to an input — from a widget, a link, a script, a test — is checked by the
session (:meth:`app.state.AppState.admit`): a bad one is refused in words, beside its input, and never set.

A room reaches the rest of the session only through its host: the model's inputs, the session's jobs
(:meth:`later`, :meth:`describe`, :attr:`jobs`) and the refusals.
"""

from __future__ import annotations

from typing import Any, ClassVar

import param

__all__ = ["Room"]


class Room(param.Parameterized):
    """One concern of the session's state (module docstring); ``host`` is the :class:`app.state.AppState`."""

    #: key (the input's name in links and messages) → the room's parameter
    KEYS: ClassVar[dict[str, str]] = {}

    def __init__(self, host: Any, **params) -> None:
        super().__init__(**params)
        self._host = host
        self._key_of = {name: key for key, name in self.KEYS.items()}

    def __setattr__(self, name: str, value) -> None:
        key = self.__dict__.get("_key_of", {}).get(name)
        if key is not None:
            admitted, value = self._host.admit(key, value)
            if not admitted:
                return
        super().__setattr__(name, value)

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
