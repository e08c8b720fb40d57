"""Server-side hardening shared by every dashboard session: patches of Panel and Bokeh (see
:mod:`app.serving.patches`, which installs them once at the server's start-up, and the development page's table).

* models the browser has not been sent stay "new" when a browser change arrives (:func:`keep_unsent_models_new`);
* one session's browser events are processed one at a time (:func:`serialize_session_events`);
* Panel lifts read-only and constant flags on a widget's own parameter objects, and on its process-wide ``state``
  under one lock (:func:`per_instance_readonly_edits`).

:func:`install` also sets Panel's public ``exception_handler`` (:func:`app.serving.session.handle_exception`) and
``notifications``; :func:`quiet_closed_websockets` is the event loop's exception handler (asyncio's public API),
and :func:`quiet_error_replies` gives the server's websocket handlers, subclasses of bokeh's, replies without server
internals (neither replaces library code).
"""

from __future__ import annotations

import contextlib
import logging
import re
import threading
import uuid
from typing import Any

import panel as pn
import tornado.websocket

from .mark import mark
from .session import handle_exception, locked

log = logging.getLogger("isl.app")

# Bokeh's property-validation errors ("ValueError(\"failed to validate Slider(...).value: expected ...")") are
# safe and useful to a client; any other ERROR reply text is withheld.
SAFE_ERROR_TEXT = re.compile(r"^\w+\((['\"])failed to validate ")
ERROR_REPLY = "The server could not apply this change (incident {incident})."

_installed = False


def install() -> None:
    """Install the exception handler, notifications and this module's patches (idempotent)."""
    global _installed
    pn.config.exception_handler = handle_exception
    pn.config.notifications = True
    if not _installed:
        keep_unsent_models_new()
        serialize_session_events()
        per_instance_readonly_edits()
        _installed = True


def quiet_closed_websockets(loop) -> None:
    """A page closed while the server was writing to it: tornado's write task then ends in ``WebSocketClosedError``
    and asyncio logs "Task exception was never retrieved" with a traceback — nothing went wrong (the reader left).
    Those become one debug line on ``loop``; every other unhandled loop error still reaches the default handler."""
    from tornado.iostream import StreamClosedError
    from tornado.websocket import WebSocketClosedError

    def handler(loop, context) -> None:
        if isinstance(context.get("exception"), WebSocketClosedError | StreamClosedError):
            log.debug("a page closed during a write: %s", context.get("message"))
        else:
            loop.default_exception_handler(context)

    loop.set_exception_handler(handler)


def quiet_error_replies(application) -> None:
    """Make the websocket handlers of a Tornado ``application`` (bokeh's, one per served app) send ``ERROR`` replies
    without a traceback and without internal exception text (idempotent).

    bokeh answers a browser message it could not apply with an ``ERROR`` reply that carries the exception's text and
    the server's traceback. Our handlers are subclasses of bokeh's whose ``send_message`` (bokeh's public method
    through which every message to the browser goes) withholds both: a property-validation error's text stays (it is
    safe and tells a client what it sent wrong, :data:`SAFE_ERROR_TEXT`), any other text becomes an incident number
    whose text and traceback go to the server's log (:func:`withhold_internals`)."""
    for rule in application.wildcard_router.rules:
        target = rule.target
        if (
            isinstance(target, type)
            and issubclass(target, tornado.websocket.WebSocketHandler)
            and not getattr(target, "_isl_quiet", False)
        ):
            rule.target = _quiet(target)


def _quiet(handler: type) -> type:
    """``handler`` (bokeh's websocket handler class) whose ``ERROR`` messages pass :func:`withhold_internals`."""

    class Quiet(handler):
        _isl_quiet = True

        async def send_message(self, message):
            if getattr(message, "msgtype", None) == "ERROR":
                withhold_internals(message)
            return await super().send_message(message)

    Quiet.__name__ = Quiet.__qualname__ = f"Quiet{handler.__name__}"
    return Quiet


def withhold_internals(message) -> None:
    """Take the traceback out of a bokeh ``ERROR`` ``message``, and its text unless :data:`SAFE_ERROR_TEXT`; what
    is withheld goes to the log under an incident number that the reply names."""
    content = dict(message.content)
    text, traceback = content.get("text") or "", content.get("traceback")
    if not SAFE_ERROR_TEXT.match(text):
        incident = uuid.uuid4().hex[:8]
        log.error("websocket ERROR reply withheld [incident %s]: %s\n%s", incident, text, traceback or "")
        content["text"] = ERROR_REPLY.format(incident=incident)
    content["traceback"] = None
    message.content = content  # (bokeh's setter: the message's JSON is made anew)


def keep_unsent_models_new() -> None:
    """Fix bokeh's bookkeeping of which models the browser knows (idempotent).

    The server sends a model in full the first time it is attached to the page, and by id later. Bokeh tracks the
    models not sent yet, but when it applies a change from the browser (``Document.apply_json_patch``) it marks
    every model of the document as sent — also those the server has just attached whose change is still held
    (Panel holds a document's events while a worker thread updates it and sends them on the next tick). The held
    change then names those models by id only, the browser rejects it ("reference p… isn't known") and every later
    change to that part of the page: seen as a page that stayed empty when the browser reported its URL while the
    dashboard was being built. Here the models that were unsent before the browser's change stay unsent; those the
    browser's change created itself count as known, as bokeh intends.
    """
    from bokeh.document.document import Document

    if getattr(Document.apply_json_patch, "_isl_keeps_unsent", False):
        return
    apply_json_patch = Document.apply_json_patch

    def apply_keeping_unsent(self, patch_json, *args, **kwargs):
        manager = self.models
        unsent = set(manager._new_models)
        try:
            return apply_json_patch(self, patch_json, *args, **kwargs)
        finally:
            manager._new_models |= {model for model in unsent if manager.get_by_id(model.id) is model}

    mark(apply_keeping_unsent, _isl_keeps_unsent=True)
    Document.apply_json_patch = apply_keeping_unsent


def serialize_session_events() -> None:
    """Process one session's browser events one at a time (idempotent).

    With ``--num-threads`` Panel processes each browser change on its thread pool, and two changes of one page on two
    threads at once: a slider sends ``value`` and ``value_throttled`` as two messages when it is released. Both
    threads then update the same widget with ``param.update``, whose batch flag is saved and restored around the
    update; interleaved, the flag stays set for good, and from then on the widget's watchers never run — the slider
    moves, the run does not (seen in ``benchmarks/bench_app_latency.py``: after 3 to 470 changes every further change
    of σ was lost, the page silent; the widget's ``param._BATCH_WATCH`` was True with 8 events queued). The same
    race can hit the dashboard's state, which every callback updates. Here each session's events (widget changes
    and UI events such as clicks) take :func:`app.serving.session.session_lock` while they are processed: other
    sessions' still run in parallel.

    A browser change is queued on the widget (``_events``) by the event loop, which schedules the processing only if
    the queue was empty; the thread then takes the queue and leaves an empty one. The loop's check and its addition
    are two steps: taken between them, the change went to the fresh queue with nothing scheduled to process it, and
    the widget was stuck the same way. Both steps now take one lock held only for them (microseconds).
    """
    from panel.io.state import set_curdoc
    from panel.reactive import Syncable

    if getattr(Syncable._change_event, "_isl_serialized", False):
        return
    server_change, bokeh_event = Syncable._server_change, Syncable._process_bokeh_event
    queue_guard = threading.RLock()  # re-entrant: without a session Panel processes the change inside _server_change

    def guarded_server_change(self, doc, ref, subpath, attr, old, new):  # bokeh checks a callback's signature
        with queue_guard:
            return server_change(self, doc, ref, subpath, attr, old, new)

    def serialized_change_event(self, doc, *args, **kwargs):  # Panel's own body, its queue taken under the guard
        with locked(doc):
            with queue_guard:
                events, self._events = self._events, {}
            with set_curdoc(doc):
                self._process_events(events)

    def serialized_bokeh_event(self, doc, *args, **kwargs):
        with locked(doc):
            return bokeh_event(self, doc, *args, **kwargs)

    for fn in (guarded_server_change, serialized_change_event, serialized_bokeh_event):
        mark(fn, _isl_serialized=True)
    Syncable._server_change = guarded_server_change
    Syncable._change_event = serialized_change_event
    Syncable._process_bokeh_event = serialized_bokeh_event


def per_instance_readonly_edits() -> None:
    """Make Panel's ``edit_readonly`` lift the flags of the object's own parameters only, and those of Panel's
    ``state`` one thread at a time (idempotent).

    To apply a browser change Panel sets every parameter of the widget to not read-only and not constant, and then
    back (``panel.util.parameters.edit_readonly``). A parameter the widget never copied is the class's object,
    shared by every session's widget of that class: two sessions' slider changes on two worker threads interleave
    there, the first restores ``constant`` while the second is setting ``value_throttled``, and the second fails with
    "Constant parameter 'value_throttled' cannot be modified" — that student's change is lost, with an incident
    notice (one change in one round of 20 pages under CPU load; the server log holds Panel's own traceback of it
    and the incident's). Here the object's read-only and constant
    parameters are copied to the instance first (param's own per-instance copy), so the flags that move are its own.

    Panel's process-wide ``state`` is one object for every session: it counts each browser event as "busy" by editing
    its read-only counter the same way, and two worker threads interleaved there failed with "Read-only parameter
    'busy' cannot be modified" (a callback error on the page, seen when several filters were ticked at once). Its
    edits take one lock, so they happen one at a time.
    """
    import sys

    from panel.io.state import state
    from panel.util import parameters

    original = parameters.edit_readonly
    if getattr(original, "_isl_per_instance", False):
        return
    shared = threading.RLock()  # re-entrant: setting the busy counter runs a watcher that edits state again

    @contextlib.contextmanager
    def edit_shared_state(parameterized):
        with shared, original(parameterized):
            yield

    def edit_own_readonly(parameterized):
        if parameterized is state:
            return edit_shared_state(parameterized)
        for name, parameter in parameterized.param.objects("existing").items():
            if parameter.readonly or parameter.constant:
                parameterized.param[name]  # param copies the parameter to the instance on access
        return original(parameterized)

    mark(edit_own_readonly, _isl_per_instance=True, _isl_original=original)
    module: Any  # any module: it is patched only if it has Panel's edit_readonly
    for name, module in list(sys.modules.items()):  # the modules that imported it by name, and later importers
        if (name == "panel" or name.startswith("panel.")) and getattr(module, "edit_readonly", None) is original:
            module.edit_readonly = edit_own_readonly
