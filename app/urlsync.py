"""The dashboard's inputs in the page's URL, so that a shared link opens the same view.

:class:`UrlSync` links an :class:`app.state.AppState` with ``pn.state.location``:

* **URL → state**, when the session opens (Back and Forward reopen it at their address, :func:`follow_history`) and
  when the page's Location reports a new address: each known query
  parameter is read by the strict parser of :mod:`app.inputs` for its declaration (no ``json``, no recursion,
  bounded length: a hostile spelling gets a message, never an exception) and set on the state in one batch
  (:meth:`app.state.AppState.set_inputs`), whose declarations judge it like a value typed in the page.
  Every value that cannot be used is reported — all of them, in one message naming
  each input and its range — and keeps its previous setting; the rest of the link still applies, and the URL is
  then rewritten to what the page shows. Inputs missing from the query take their defaults.
* **state → URL**: the query holds the inputs that differ from their defaults (``?sigma=200&nu=0.5``). In a served
  session it is written once the inputs have rested :data:`URL_PAUSE` s and the change has been answered (the run it
  started applied, refused or failed) — not with the new plots: the browser applies a patch's changes in order, and
  the URL's came first, so its history update (and the page's report of its new address back to the server) ran
  ahead of the plots' data and redraw (what it saves: :ref:`performance-latency`). While a slider is dragged the URL
  waits until the drag pauses (a write during the
  drag would land in the middle of the next update). Outside a served session (tests, scripts) it is written at
  once.
"""

from __future__ import annotations

import json
import time
import urllib.parse
from collections.abc import Callable

from . import inputs
from .serving.session import session_loop
from .state import ALL_INPUTS, AppState, declaration, input_label

__all__ = [
    "URL_INPUTS",
    "URL_PAUSE",
    "UrlSync",
    "after_pause",
    "follow_history",
    "parse_query",
    "query_string",
    "read_query",
]

URL_INPUTS = ALL_INPUTS  #: the inputs a link carries
MAX_QUERY = 65536  #: characters of a query read at all (tornado refuses longer request lines anyway)
MAX_FIELDS = 200  #: key=value pairs of a query read at all
_OUTCOMES = ["run", "message", "busy"]  #: a run was applied, refused or failed: the change has been answered
URL_PAUSE = 0.3  #: seconds the inputs rest, once answered, before the URL follows them (served sessions)


def after_pause(doc) -> Callable[[Callable[[], None], float], None] | None:
    """``defer(fn, after)``: call ``fn`` ``after`` seconds from now on the event loop that serves ``doc``'s session
    (``defer`` may be called from any thread: the page itself is built on a thread of its own,
    :mod:`app.serving.offloop`); None outside a served session."""
    loop = session_loop(doc)
    if loop is None:
        return None
    return lambda fn, after: loop.add_callback(loop.call_later, after, fn)


#: Back and Forward reload the page at the address they reach: a new session opens that view. Panel's Location follows
#: ``hashchange`` only; handing it the new query instead (an in-page update) crossed with the server's own pending
#: write of the address: the browser then showed the server's older address over the view it had gone back to
HISTORY_JS = "window.addEventListener('popstate', () => window.location.reload());"


def follow_history(doc) -> None:
    """Back and Forward in the browser restore the view their URL names: the page reloads at that address
    (:data:`HISTORY_JS`). Nothing without a document."""
    if doc is not None:
        from bokeh.models import CustomJS

        doc.js_on_event("document_ready", CustomJS(code=HISTORY_JS))


def _encode(value) -> str:
    """A value as the link spells it: shortest exact form, integral numbers without ".0" (``sigma=200``)."""
    if isinstance(value, float):
        text = repr(value)
        return text[:-2] if text.endswith(".0") else text
    if isinstance(value, str):  # a choice: its name as is (sc_noise=student)
        return value
    if isinstance(value, list | tuple):
        return "[" + ",".join(_encode(v) if not isinstance(v, str) else json.dumps(v) for v in value) + "]"
    return json.dumps(value)


def read_query(search: str) -> tuple[dict[str, object], dict[str, str]]:
    """The known inputs of a URL query (``"?sigma=200&m=2"``) parsed, and a message for each value that cannot be
    read (input name → message naming the input and its range). Unknown keys are left out; a repeated key counts
    once (its last value). Never raises, whatever the text."""
    search = search if isinstance(search, str) else ""
    if len(search) > MAX_QUERY:
        return {}, {
            "": f"the link's query is {len(search):,} characters long (at most {MAX_QUERY:,} are read); "
            "every input keeps its default"
        }
    try:
        pairs = urllib.parse.parse_qsl(search.lstrip("?"), keep_blank_values=True, max_num_fields=MAX_FIELDS)
    except ValueError:
        return {}, {"": f"the link has more than {MAX_FIELDS} values; every input keeps its default"}
    values: dict[str, object] = {}
    problems: dict[str, str] = {}
    for key, text in pairs:
        if key not in URL_INPUTS:
            continue
        p = declaration(key)
        try:
            values[key] = inputs.parse_text(text, p)
            problems.pop(key, None)
        except ValueError as exc:
            values.pop(key, None)
            problems[key] = f"{input_label(key, link=True)} must be {inputs.allowed(p)}; {exc}"
    return values, problems


def parse_query(search: str) -> dict[str, object]:
    """The readable known inputs of a URL query (:func:`read_query` without its messages)."""
    return read_query(search)[0]


def query_string(state: AppState, search: str = "") -> str:
    """``search`` with the known inputs replaced by the state's non-default ones (unknown keys are kept)."""
    kept = [
        (k, v) for k, v in urllib.parse.parse_qsl(search.lstrip("?"), keep_blank_values=True) if k not in URL_INPUTS
    ]
    ours = [(n, _encode(state.get(n))) for n in URL_INPUTS if state.get(n) != declaration(n).default]
    query = urllib.parse.urlencode(kept + ours, safe="[],:")
    return f"?{query}" if query else ""


class UrlSync:
    """Two-way link between ``state``'s inputs and ``location`` (a Panel ``Location``), see the module doc."""

    def __init__(
        self,
        state: AppState,
        location,
        defer: Callable[[Callable[[], None], float], None] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        """``defer(fn, after)`` runs ``fn`` ``after`` seconds later (:func:`after_pause`); without it the URL is
        written at once. ``clock``: seconds, for the time since the last input changed."""
        self.state, self.location = state, location
        self._defer, self._clock = defer, clock
        self._armed = False  # a deferred write is on its way
        self._moved = -float("inf")  # when an input last changed (clock)
        self._writing = False
        self._pending = False
        # The page's own copy of its URL reports the query it was opened with once, when it loads — after the server
        # may already have rewritten it (a bad value dropped, a horizon lowered). That echo is not a navigation.
        self._opened_with = location.search
        self.apply(location.search)
        state.watch(self._on_input, URL_INPUTS)
        state.param.watch(self._on_outcome, _OUTCOMES)
        location.param.watch(self._on_search, ["search"])

    def apply(self, search: str) -> None:
        """Set the state's inputs from ``search``: the query's values, defaults for the inputs it lacks; every bad
        value is reported (one message) and the URL then shows what the page shows."""
        values, problems = read_query(search)
        wanted = {n: declaration(n).default for n in URL_INPUTS}
        wanted.update(values)
        changed = {n: v for n, v in wanted.items() if not _same(self.state.get(n), v)}
        bad = self.state.set_inputs(changed, problems, link=True)  # in one batch: one new run for the whole link
        if bad and self.state.computing:
            self._pending = True  # cleaned with the answer to the rest of the link
        elif bad:
            self.write()

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
        self._pending = True
        self._moved = self._clock()
        if not self.state.computing:  # else written once it is answered (see _on_outcome)
            self._write_soon()

    def _on_outcome(self, *events) -> None:
        if self._pending and not self.state.computing:
            self._write_soon()

    def _write_soon(self) -> None:
        if self._defer is None:
            self.write()
        elif not self._armed:
            self._armed = True
            self._defer(self._paused, URL_PAUSE)

    def _paused(self) -> None:  # on the loop: once the inputs have rested, the write goes out with the session's lock
        rest = self._moved + URL_PAUSE - self._clock()
        if rest > 0:  # an input moved since the pause began: wait until it has rested as long
            assert self._defer is not None  # a pause is only ever scheduled through it
            self._defer(self._paused, rest)
            return
        self._armed = False
        self.state.later(self._write_if_settled)

    def _write_if_settled(self) -> None:
        if self._pending and not self.state.computing:  # else a newer change is being answered: written after it
            self.write()

    def _on_search(self, event) -> None:
        if self._writing:  # our own write
            return
        echo, self._opened_with = event.new == self._opened_with, None
        if echo:
            self.write()  # the page reloaded the query it was opened with: give it back what is shown
        else:
            self.apply(event.new)


def _same(a, b) -> bool:
    try:
        return bool(a == b)
    except Exception:  # noqa: BLE001  (any value's own __eq__ may raise, e.g. numpy's ambiguous truth: not the same)
        return False
