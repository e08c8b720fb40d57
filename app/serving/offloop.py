"""Build each session's page off the server's event loop.

Bokeh creates a session on the event loop: it awaits the application's ``on_session_created`` hooks, then runs the
app script (``initialize_document``) right there. The script builds the page's Panel objects and their bokeh models
— while the loop answers nobody: not the other students' slider changes, not ``/liveness``
(:ref:`performance-page-building`). Two changes move that work to a thread:

* :class:`OffLoopApplication`, the application the server serves, runs the app script (Panel's
  ``initialize_document``) on one page-building thread, awaited from its ``on_session_created``, which bokeh awaits
  (the session is registered as *pending* meanwhile, so a second request for it waits for the same build); bokeh's
  own call right after it does nothing for that document. Nothing else can see the document yet: it has no session,
  no connection and no callbacks running. Once it is built, Panel's record of the document's thread is set back to
  the event loop's, where the session lives from then on. One thread, so that no two app scripts run at once (the
  script runner swaps ``sys.modules`` entries and bokeh's output functions while it runs). It is a subclass of
  Panel's application, made by the serve command's public ``customize_applications``: no library code is replaced.
* :func:`app.serving.session.prebuild` (called by :func:`app.page.deferred` on the thread that evaluates a deferred
  part) builds that part's bokeh models before Panel attaches it: Panel reuses a component's models when it already
  has them for the page's root, so the event loop only attaches them instead of building them.

Both rely on bokeh's ``curdoc()`` being right on each thread; bokeh keeps its stack of patched documents in one
list for the whole process, so a build on the page thread and a callback on the loop would see each other's
document. :func:`install` makes that stack per thread.

Builds on threads also register Panel's links (``jslink``, a widget's ``js_on_click``) in ``Callback.registry``, one
dictionary for the whole process, which the event loop iterates whenever it attaches a part to a page. A
registration in the middle of that iteration raised "dictionary changed size during iteration" and the part was
never attached: a page kept its loading spinner where its controls should be. :func:`install` makes that registry
iterate over a snapshot.

Work done on a thread reaches the page through a callback on the session's loop: a job's outcome
(:class:`app.page.SessionGate`) and Panel's own model updates both call ``pn.state.execute(..., schedule=True)``,
which registers the callback with the document right there, on the worker thread. The registration is a document
event, and while the loop holds the document (it does so around every outcome it applies) the event is queued in
the hold; the loop's ``unhold`` takes that queue and leaves a fresh one, in two steps that a worker thread can fall
between, and then the registration went into a queue nobody reads: the callback never ran. For a job's outcome
that meant the session's run stayed "in flight" for good, every later slider change waited behind it, and the page
stopped following its sliders (how rare, and how it was found: :ref:`performance-page-building`). :func:`install` makes
``execute`` hand such a callback to the
session's loop first (tornado's thread-safe ``add_callback``), which registers it there.

:func:`install` is idempotent; :func:`app.serving.patches.install` calls it at the server's start-up (and
:meth:`OffLoopApplication.like` before it makes an application).
"""

from __future__ import annotations

import asyncio
import logging
import os
import threading
import weakref

from panel.io.application import Application

from .session import PAGE_POOL, session_loop

__all__ = ["OffLoopApplication", "PerThreadStack", "SnapshotRegistry", "install"]

log = logging.getLogger(__name__)
pages_log = logging.getLogger("isl.pages")  #: one line per page built (its session and process: serving-many)


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
    threads add to it, and callbacks scheduled from a thread registered by the session's loop (idempotent)."""
    import bokeh.io.doc as bk_doc
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


def _on_loop(loop) -> bool:
    try:
        return asyncio.get_running_loop() is loop.asyncio_loop
    except RuntimeError:  # no loop runs on this thread: a worker thread
        return False


def _execute_via_loop(execute):
    """Panel's ``state.execute``, except that a callback it would schedule on a served session's loop from another
    thread is handed to that loop first, which registers it with the document (see the module's docstring)."""
    from param.parameterized import iscoroutinefunction

    def execute_via_loop(self, callback, schedule="auto"):
        doc = self.curdoc
        loop = session_loop(doc)
        if (
            loop is not None
            and (schedule is True or (schedule == "auto" and not self._unblocked(doc)))
            and not iscoroutinefunction(callback)
            and not _on_loop(loop)
        ):  # Panel: add_next_tick_callback
            loop.add_callback(_register, doc, self._handle_exception_wrapper(callback, doc))
            return None
        return execute(self, callback, schedule)

    execute_via_loop._isl_original = execute
    return execute_via_loop


def _register(doc, callback) -> None:
    """On the session's loop: run ``callback`` on its next tick, with the document locked (bokeh's session callback)."""
    from bokeh.io import doc as bokeh_doc

    patched = bokeh_doc._PATCHED_CURDOCS
    depth = len(patched)
    try:
        doc.add_next_tick_callback(callback)
    except (RuntimeError, AttributeError):
        # the session was destroyed meanwhile (bokeh's document without its callback manager): nobody sees the outcome;
        # bokeh had made the destroyed document this thread's curdoc() before it failed: what runs next must not see it
        while len(patched) > depth:
            patched.pop()
        log.debug("dropped a callback of a destroyed session", exc_info=True)


class OffLoopApplication(Application):
    """Panel's application (``panel.io.application.Application``, what ``panel serve`` serves), building each new
    session's document on :data:`PAGE_POOL` instead of the event loop.

    Bokeh awaits :meth:`on_session_created` (the session is registered as *pending* meanwhile, so a second request
    for it waits for the same build) and then calls :meth:`initialize_document` on the loop. Here the first runs
    Panel's and the handlers' session hooks, then Panel's own ``initialize_document`` on the page thread, awaited;
    the second does nothing for a document built so. Every duty of Panel's and bokeh's ``initialize_document`` —
    the app script's handlers with their error page, the session's URL prefix, the template, the document's
    validation — is done as before, on the thread. The server serves applications of this class: the serve command
    makes them (:meth:`like`) in bokeh's public ``customize_applications`` hook (:mod:`!app.serving.serve`)."""

    def __init__(self, *handlers, **kwargs) -> None:
        super().__init__(*handlers, **kwargs)
        self._built: weakref.WeakSet = weakref.WeakSet()  # documents built in on_session_created, not yet initialized

    @classmethod
    def like(cls, application) -> OffLoopApplication:
        """An application with ``application``'s handlers and metadata (one the serve command built), after
        :func:`install`: what a build on a thread relies on."""
        install()
        return cls(*application.handlers, metadata=application.metadata)

    async def on_session_created(self, session_context) -> None:
        """Panel's and the handlers' session hooks (on the loop), then the session's document built on the page
        thread (awaited)."""
        await super().on_session_created(session_context)
        await session_context.with_locked_document(self._build)  # before the session exists: the document alone
        pages_log.info("isl page: built for session %s in process %d", session_context.id, os.getpid())

    async def _build(self, doc) -> None:
        from panel.io.state import state

        loop_thread = threading.get_ident()
        await asyncio.get_running_loop().run_in_executor(PAGE_POOL, super().initialize_document, doc)
        state._thread_id_[doc] = loop_thread  # Panel's record: the session's document belongs to the loop from now on
        self._built.add(doc)

    def initialize_document(self, doc) -> None:
        """Nothing for a document :meth:`on_session_created` built; any other (a page built outside a session's
        creation, such as the start-up pages of :func:`app.serving.pages.build_pages`) as Panel builds it."""
        if doc in self._built:
            self._built.discard(doc)
            return
        super().initialize_document(doc)
