"""Build each session's page off the server's event loop.

Bokeh creates a session on the event loop: it awaits the application's ``on_session_created`` hooks, then runs the
app script (``initialize_document``) right there. The script builds the page's Panel objects and their bokeh models
— ≈ 150–290 ms of Python a page (py-spy, classroom scenario) during which the loop answered nobody: not the other
students' slider changes, not ``/liveness``. Two changes move that work to a thread:

* :func:`build_pages_off_loop` runs ``initialize_document`` on one page-building thread, awaited from the
  ``on_session_created`` hook (which bokeh awaits; the session is registered as *pending* meanwhile, so a second
  request for it waits for the same build), and makes bokeh's own call right after it a no-op for that document.
  Nothing else can see the document yet: it has no session, no connection and no callbacks running. Once it is
  built, Panel's record of the document's thread is set back to the event loop's, where the session lives from then
  on. One thread, so that no two app scripts run at once (the script runner swaps ``sys.modules`` entries and
  bokeh's output functions while it runs).
* :func:`prebuild` (called by :func:`app.page.deferred` on the thread that evaluates a deferred part) builds that
  part's bokeh models before Panel attaches it: Panel reuses a component's models when it already has them for the
  page's root, so the event loop only attaches them instead of building them.

Both rely on bokeh's ``curdoc()`` being right on each thread; bokeh keeps its stack of patched documents in one
list for the whole process, so a build on the page thread and a callback on the loop would see each other's
document. :func:`install` makes that stack per thread.

Builds on threads also register Panel's links (``jslink``, a widget's ``js_on_click``) in ``Callback.registry``, one
dictionary for the whole process, which the event loop iterates whenever it attaches a part to a page. A
registration in the middle of that iteration raised "dictionary changed size during iteration" and the part was
never attached: a page kept its loading spinner where its controls should be (1 page of 20 in a CI load run, and
in 1 round of 21 here with 20 pages opening under CPU load). :func:`install` makes that registry iterate over a
snapshot.

Work done on a thread reaches the page through a callback on the session's loop: a job's outcome
(:class:`app.page.SessionGate`) and Panel's own model updates both call ``pn.state.execute(..., schedule=True)``.
Panel registers the callback with the document right there, on the worker thread, as a document event; while the
loop holds the document the event is queued in the hold, and the loop's ``unhold`` takes that queue and leaves a
fresh one in two steps a worker thread can fall between: the registration then went into a queue nobody reads and
the callback never ran (a job's outcome: the session's run stayed "in flight" for good and the page stopped
following its sliders; CI's load run, 1 session of 20; a stress run of the same steps lost 1 registration in
20 000). :func:`install` makes ``execute`` hand such a callback to the session's loop (tornado's thread-safe
``add_callback``), which registers it there.

**Applied off the loop.** Applying such a callback — swapping a part into the page, a run's outcome into the
plots — makes bokeh walk the document's models and serialize the new ones and the changed data into messages:
30–110 ms of Python a part on an idle server, over a second under a class's load, during which the loop answered
nobody. Bokeh runs a session callback with the session's document locked (an asyncio lock: the session's browser
messages and other callbacks wait for it) and, if the callback returns an awaitable, awaits it before it unlocks
the document and writes the messages the changes made. The loop's callback now only returns the future of the
work on an apply thread (:data:`APPLY_POOL`): the document is locked for that thread the whole time, the thread is
Panel's thread of the document meanwhile (so that Panel applies model changes made there at once, as on the loop),
and the messages are made there and written by the loop once it is done. Two things keep the loop off a document
an apply thread works on: an event the loop would add to it (registering another callback) waits until the thread
is done — the thread may hold the document's events and its ``unhold`` would lose it as above; and a session's
connections are iterated over a copy, since the loop adds and drops them. Opening three default pages one after
another, the loop's time in callbacks over 2 ms went from 1 102 to 184 ms.
"""
from __future__ import annotations

import asyncio
import logging
import threading
import weakref
from concurrent.futures import ThreadPoolExecutor
from functools import partial

log = logging.getLogger(__name__)

#: the one thread that runs the app script for new sessions
PAGE_POOL = ThreadPoolExecutor(max_workers=1, thread_name_prefix="isl-page")
#: the threads that apply work done on other threads to a page (a job's outcome, a part swapped in), each with the
#: session's document locked for it
APPLY_POOL = ThreadPoolExecutor(max_workers=2, thread_name_prefix="isl-apply")


class PerThreadStack(threading.local):
    """A list-like stack with one list per thread: what bokeh's ``patch_curdoc`` pushes on one thread is what
    ``curdoc()`` on that thread sees, whatever the others push."""

    def __init__(self) -> None:
        self.items: list = []

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, index):
        return self.items[index]

    def append(self, item) -> None:
        self.items.append(item)

    def pop(self):
        return self.items.pop()

    def clear(self) -> None:
        self.items.clear()


class SnapshotRegistry(weakref.WeakKeyDictionary):
    """A ``WeakKeyDictionary`` whose iteration walks a copy: another thread may add a key meanwhile.

    The copy is one C-level ``dict.copy`` of the weak references (no Python code and no garbage collection runs in
    it, so no thread switch and no weak-reference callback can change the dictionary halfway through)."""

    def items(self):
        for ref, value in self.data.copy().items():
            key = ref()
            if key is not None:
                yield key, value

    def keys(self):
        for key, _ in self.items():
            yield key

    __iter__ = keys

    def values(self):
        for _, value in self.items():
            yield value


def install() -> None:
    """Make bokeh's patched-``curdoc()`` stack per thread, Panel's link registry safe to iterate while other
    threads add to it, and callbacks scheduled on a session's loop applied on an apply thread (idempotent)."""
    import bokeh.io.doc as bk_doc
    import panel.io.document as pn_document
    from bokeh.document.callbacks import DocumentCallbackManager
    from bokeh.server.session import ServerSession
    from panel.io.state import _state
    from panel.links import Callback

    if not isinstance(bk_doc._PATCHED_CURDOCS, PerThreadStack):
        stack = PerThreadStack()
        stack.items.extend(bk_doc._PATCHED_CURDOCS)
        bk_doc._PATCHED_CURDOCS = stack
    if not isinstance(Callback.registry, SnapshotRegistry):
        Callback.registry = SnapshotRegistry(Callback.registry)
    if not hasattr(_state.execute, "_isl_original"):
        _state.execute = _execute_via_loop(_state.execute)
    if not hasattr(DocumentCallbackManager.trigger_on_change, "_isl_original"):
        DocumentCallbackManager.trigger_on_change = _defer_while_applying(DocumentCallbackManager.trigger_on_change)
    for name in ("write_events", "schedule_write_events"):
        if not hasattr(getattr(pn_document, name), "_isl_original"):
            setattr(pn_document, name, _writes_after_apply(getattr(pn_document, name)))
    if not hasattr(ServerSession.__init__, "_isl_original"):
        ServerSession.__init__ = _snapshot_connections(ServerSession.__init__)


def _snapshot_connections(init):
    def __init__(self, *args, **kwargs) -> None:
        init(self, *args, **kwargs)
        self._subscribed_connections = SnapshotSet(self._subscribed_connections)

    __init__._isl_original = init
    return __init__


def session_loop(doc):
    """The tornado ``IOLoop`` serving ``doc``'s session; None outside a served session."""
    context = getattr(doc, "session_context", None)
    server = getattr(context, "server_context", None)
    return getattr(getattr(server, "application_context", None), "io_loop", None)


def _on_loop(loop) -> bool:
    if loop is None:
        return False
    try:
        return asyncio.get_running_loop() is loop.asyncio_loop
    except RuntimeError:  # no loop runs on this thread: a worker thread
        return False


def _execute_via_loop(execute):
    """Panel's ``state.execute``, except that a callback it would schedule on a served session's loop is registered by
    that loop (handed to it first, from a thread), and Panel's model updates made on a thread (a part swapped into the
    page) are applied on an apply thread with the document locked (see the module's docstring)."""
    from param.parameterized import iscoroutinefunction

    def execute_via_loop(self, callback, schedule="auto"):
        doc = self.curdoc
        loop = session_loop(doc)
        if (loop is not None and (schedule is True or (schedule == "auto" and not self._unblocked(doc)))
                and not iscoroutinefunction(callback)):  # Panel: add_next_tick_callback
            wrapped = self._handle_exception_wrapper(callback, doc)
            off_loop = getattr(getattr(callback, "func", None), "__name__", "") == "_scheduled_update_model"
            if _on_loop(loop):
                _register(doc, wrapped, off_loop)
            else:
                loop.add_callback(_register, doc, wrapped, off_loop)
            return None
        return execute(self, callback, schedule)

    execute_via_loop._isl_original = execute
    return execute_via_loop


def _register(doc, callback, off_loop: bool = False) -> None:
    """On the session's loop: run ``callback`` on its next tick with the document locked — ``off_loop``, on an apply
    thread."""
    try:
        doc.add_next_tick_callback(partial(_apply_locked, doc, callback) if off_loop else callback)
    except RuntimeError:  # the session was destroyed meanwhile: nobody is left to see the outcome
        log.debug("dropped a callback of a destroyed session", exc_info=True)


class _Applying:
    """A document an apply thread works on: that thread (once it runs), and what the loop left for after it."""

    __slots__ = ("deferred", "thread")

    def __init__(self) -> None:
        self.thread: int | None = None
        self.deferred: list = []


#: documents an apply thread works on now (each locked for it by bokeh)
_APPLYING: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _apply_locked(doc, callback):
    """Bokeh runs this on the loop with the session's document locked: it hands ``callback`` to an apply thread and
    returns the future that bokeh awaits, still locked, before it writes the messages the callback's changes made."""
    applying = _APPLYING[doc] = _Applying()
    future = asyncio.get_running_loop().run_in_executor(APPLY_POOL, _apply, doc, callback, applying)
    future.add_done_callback(lambda _: _release(doc, applying))
    return future


def _apply(doc, callback, applying: _Applying) -> None:
    """On an apply thread: ``callback`` with ``doc`` as this thread's document (bokeh's ``curdoc``, Panel's thread of
    the document, so that Panel applies the model changes made here at once, as it does on the loop)."""
    from bokeh.io.doc import patch_curdoc
    from panel.io.state import state

    applying.thread = threading.get_ident()
    owner = state._thread_id_.get(doc)
    state._thread_id_[doc] = applying.thread
    try:
        with patch_curdoc(doc):
            callback()
    finally:
        if owner is None:
            state._thread_id_.pop(doc, None)
        else:
            state._thread_id_[doc] = owner


def _release(doc, applying: _Applying) -> None:
    """On the loop, once the apply thread is done with ``doc``: what the loop left for after it, in order."""
    if _APPLYING.get(doc) is applying:
        del _APPLYING[doc]
    for deferred in applying.deferred:
        deferred()


def _defer_while_applying(trigger):
    """Bokeh's ``DocumentCallbackManager.trigger_on_change``, except on the loop for a document an apply thread works
    on: the event (a callback registered with the document) is triggered once that thread is done. The thread may
    hold the document's events, and its ``unhold`` takes them in two steps: an event the loop queued between them
    would be lost. Other threads are left as Panel has them (its threaded ``hold`` lifts the hold around the
    registration it makes, so that the event is dispatched at once, and needs it then)."""

    def trigger_on_change(self, event) -> None:
        doc = self._document()
        applying = _APPLYING.get(doc) if doc is not None else None
        if applying is not None and applying.thread != threading.get_ident() and _on_loop(session_loop(doc)):
            applying.deferred.append(partial(trigger_on_change, self, event))
            return None
        return trigger(self, event)

    trigger_on_change._isl_original = trigger
    return trigger_on_change


def _writes_after_apply(write):
    """Panel's ``write_events`` (or ``schedule_write_events``), except on an apply thread: there the messages are
    made at once and written by the loop after the callback, in order with bokeh's own (the session's pending
    writes, which bokeh awaits before it unlocks the document) — a websocket is written from its loop only."""

    def write_events(doc, connections, events):
        applying = _APPLYING.get(doc)
        session = getattr(getattr(doc, "session_context", None), "session", None)
        pending = getattr(session, "_pending_writes", None)
        if applying is None or applying.thread != threading.get_ident() or pending is None:
            return write(doc, connections, events)
        for connection in list(connections):
            socket = getattr(connection, "_socket", None)
            closing = getattr(socket, "ws_connection", None)
            if closing is None or closing.is_closing():
                continue
            pending.append(socket.send_message(connection.protocol.create("PATCH-DOC", events)))
        return None

    write_events._isl_original = write
    return write_events


class SnapshotSet(set):
    """A set whose iteration walks a copy (one C-level copy): the loop may add or drop a connection of a session
    while an apply thread sends to the others."""

    def __iter__(self):
        return iter(set.copy(self))


def build_pages_off_loop(application) -> None:
    """Make ``application`` (a bokeh/Panel ``Application``) build each new session's document on
    :data:`PAGE_POOL` instead of the event loop (idempotent)."""
    if getattr(application, "_isl_pages_off_loop", False):
        return
    install()
    from panel.io.state import state

    created, initialize = application.on_session_created, application.initialize_document
    built: weakref.WeakSet = weakref.WeakSet()

    async def on_session_created(session_context) -> None:
        await created(session_context)
        doc = session_context._document
        loop_thread = threading.get_ident()
        await asyncio.get_running_loop().run_in_executor(PAGE_POOL, initialize, doc)
        state._thread_id_[doc] = loop_thread  # the session's document belongs to the loop from now on
        built.add(doc)

    def initialize_document(doc) -> None:
        if doc in built:
            built.discard(doc)
            return
        initialize(doc)

    application.on_session_created = on_session_created
    application.initialize_document = initialize_document
    application._isl_pages_off_loop = True


def prebuild(obj, container) -> None:
    """Build ``obj``'s bokeh models for every page root ``container`` is shown in, where ``obj`` will become
    ``container``'s child; models built here are not attached to any document until Panel swaps ``obj`` in on the
    event loop (it then reuses them). Outside a server session there is nothing to do."""
    from panel.io.state import state

    for ref, (model, _) in list(container._models.items()):
        view = state._views.get(ref)
        if view is None or view[3] is not None:  # no longer shown, or a notebook comm: leave it to Panel
            continue
        _, root, doc, _ = view
        if doc is None or doc.session_context is None or ref in obj._models:
            continue
        obj._get_model(doc, root, model, None)
