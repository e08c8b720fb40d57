"""The dashboard's inputs in the page's URL, so that a shared link opens the same view.

:class:`UrlSync` links an :class:`app.state.AppState` with ``pn.state.location``:

* **URL → state**, when the session opens and when the browser navigates (back/forward): each known query
  parameter is parsed as JSON (a bare word stays a string) and set on the state, which validates it like a value
  typed in the page: ``?sigma=-3`` or ``?m=abc`` is refused with a message naming the parameter, and the rest of
  the link still applies. Inputs missing from the query take their defaults.
* **state → URL**: the query holds the inputs that differ from their defaults (``?sigma=200&nu=0.5``). It is
  written when the change has been answered — with the run it started, in the same message as the new plots —
  not the moment an input moves: a write on its own costs the server a message of its own and the browser a
  history update ahead of the plots, on every slider step (about 10 ms of a redraw, measured with
  ``benchmarks/bench_app_latency.py``). Inputs that start no run (the sweep's, the worst case's) are written at
  once.
"""
from __future__ import annotations

import json
import urllib.parse

import param

from . import extras
from .state import INPUTS, SWEEP_INPUTS, AppState

__all__ = ["URL_INPUTS", "UrlSync", "parse_query", "query_string"]

URL_INPUTS = (*INPUTS, *SWEEP_INPUTS, *extras.INPUTS)  #: the inputs a link carries
_OUTCOMES = ["run", "message", "busy"]  #: a run was applied, refused or failed: the change has been answered


def _decode(text: str):
    try:
        return json.loads(text)
    except ValueError:
        return text  # not JSON: the state refuses it with a message naming the parameter


def _encode(value) -> str:
    return json.dumps(list(value) if isinstance(value, tuple) else value, separators=(",", ":"))


def parse_query(search: str) -> dict[str, object]:
    """The known inputs in a URL query (``"?sigma=200&m=2"``), decoded; unknown keys are left out."""
    pairs = urllib.parse.parse_qsl(search.lstrip("?"), keep_blank_values=True)
    return {k: _decode(v) for k, v in pairs if k in URL_INPUTS}


def query_string(state: param.Parameterized, search: str = "") -> str:
    """``search`` with the known inputs replaced by the state's non-default ones (unknown keys are kept)."""
    kept = [(k, v) for k, v in urllib.parse.parse_qsl(search.lstrip("?"), keep_blank_values=True)
            if k not in URL_INPUTS]
    ours = [(n, _encode(getattr(state, n))) for n in URL_INPUTS if getattr(state, n) != state.param[n].default]
    query = urllib.parse.urlencode(kept + ours, safe="[],:")
    return f"?{query}" if query else ""


class UrlSync:
    """Two-way link between ``state``'s inputs and ``location`` (a Panel ``Location``), see the module doc."""

    def __init__(self, state: AppState, location) -> None:
        self.state, self.location = state, location
        self._writing = False
        self._pending = False
        self.apply(location.search)
        state.param.watch(self._on_input, list(URL_INPUTS))
        state.param.watch(self._on_outcome, _OUTCOMES)
        location.param.watch(self._on_search, ["search"])

    def apply(self, search: str) -> None:
        """Set the state's inputs from ``search``: the query's values, defaults for the inputs it lacks."""
        wanted = {n: self.state.param[n].default for n in URL_INPUTS}
        wanted.update(parse_query(search))
        changed = {n: v for n, v in wanted.items() if not _same(getattr(self.state, n), v)}
        with param.parameterized.batch_call_watchers(self.state):  # one new run for the whole link
            for name, value in changed.items():
                setattr(self.state, name, value)  # validated by the state; a bad value is refused

    def write(self) -> None:
        self._pending = False
        search = query_string(self.state, self.location.search)
        if search != self.location.search:
            self._writing = True
            try:
                self.location.search = search
            finally:
                self._writing = False

    def _on_input(self, *events) -> None:
        if self._writing:
            return
        if self.state.computing:
            self._pending = True  # written with the answer (see _on_outcome)
        else:
            self.write()

    def _on_outcome(self, *events) -> None:
        if self._pending and not self.state.computing:
            self.write()

    def _on_search(self, event) -> None:
        if not self._writing:
            self.apply(event.new)


def _same(a, b) -> bool:
    try:
        return bool(a == b)
    except Exception:  # noqa: BLE001 — incomparable values differ
        return False
