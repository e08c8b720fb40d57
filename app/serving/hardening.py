"""Server-side hardening shared by every dashboard session.

What :func:`install` sets up (idempotent; :mod:`app.serving.serve` calls it once in the server process before any
session exists, so it applies to every session; ``app/app.py`` may call it too, which makes a plain
``panel serve app/app.py`` just as safe):

* ``pn.config.exception_handler`` = :func:`handle_exception`: an exception escaping a widget or param
  callback is logged with its full traceback to the server log (logger ``isl.app``) under a short incident id,
  and the user sees a notification with that id and no traceback, no exception text, no file paths.
* ``pn.config.notifications = True``, so that every session has a place to show that message.
* models the browser has not been sent stay "new" when a browser change arrives (:func:`keep_unsent_models_new`),
  so the server's next change sends them in full instead of by id, which the browser rejects.
* one session's browser events are processed one at a time (:func:`serialize_session_events`): Panel hands each to
  its thread pool, and two at once corrupted param's bookkeeping so that a slider stopped moving the run.
* Panel lifts a widget's read-only and constant flags on that widget's own parameter objects while it applies a
  browser change (:func:`per_instance_readonly_edits`), not on the class's, which every session's widgets share.
* every stylesheet of the page is served by the server itself (:func:`local_stylesheets`).
* a link whose value Panel's own query parser cannot convert (a 5000-digit number) opens the page instead of failing
  its script (:func:`tolerant_query_parser`).
* websocket ``ERROR`` replies without server internals: bokeh answers a message it cannot apply (e.g. a scripted
  client setting a slider to a string) with an ``ERROR`` reply that carries the server's full traceback. The
  traceback is dropped (bokeh's protocol handler already logs it), and a reply text that is not bokeh's own
  property-validation message is replaced by a short text with an incident id (:func:`quiet_error_replies`).

Per session, :func:`release_on_destroy` registers a release hook on the session's document
(``on_session_destroyed``): when the server destroys the session (its tab closed and
``--unused-session-lifetime`` elapsed) — or Panel discards its warm-up session — the hook drops the session's
large data (the latest ``Run``: a few (N+1)×m arrays, several MB on long runs) at once, even if something still
holds the session's objects (bokeh's ``Document.destroy`` then runs a full garbage collection).

Usage inside a session (e.g. in ``create_app()``)::

    state = AppState()
    hardening.release_on_destroy(state.close)   # or an object: its release(), else its payload attributes
"""

from __future__ import annotations

import contextlib
import logging
import re
import threading
import uuid
import weakref
from collections.abc import Callable
from typing import Any

import panel as pn
import param

from .patches import mark

log = logging.getLogger("isl.app")

USER_MESSAGE = (
    "Something went wrong while updating the dashboard (incident {incident}). "
    "The last good result is still shown; the server log has the details."
)
NOTIFICATION_MS = 8000
# Outputs of app.state.AppState that hold a session's large data (the run's arrays, their display copies, the
# sweep's curves and points); on a param.Parameterized they are reset to their defaults.
PAYLOAD_ATTRS = ("run", "traces", "prediction", "curves", "points")
# Bokeh's property-validation errors ("ValueError(\"failed to validate Slider(...).value: expected ...")") are
# safe and useful to a client; any other ERROR reply text is withheld.
SAFE_ERROR_TEXT = re.compile(r"^\w+\((['\"])failed to validate ")
ERROR_REPLY = "The server could not apply this change (incident {incident})."

_installed = False
_releases: dict[str, list[Callable[[], None]]] = {}


def install() -> None:
    """Install the exception handler, notifications and quiet websocket error replies (idempotent)."""
    global _installed
    pn.config.exception_handler = handle_exception
    pn.config.notifications = True
    if not _installed:
        quiet_error_replies()
        keep_unsent_models_new()
        serialize_session_events()
        per_instance_readonly_edits()
        tolerant_query_parser()
        local_stylesheets()
        _installed = True


def local_stylesheets() -> None:
    """Panel points a stylesheet at its CDN (cdn.holoviz.org) when the document it builds a component for has no
    ``dist_url`` — the warm-up's document has none — and shares that stylesheet model between documents: a page
    asked the CDN for ``loading.css`` when the who-wins map started to compute (a classroom without internet then
    waits on a request that fails). The server serves Panel's files itself: no stylesheet is pointed at the CDN."""
    from panel import reactive
    from panel.io import resources

    original = resources.patch_stylesheet
    if getattr(original, "_isl_local", False):
        return

    def local(stylesheet, dist_url):
        return original(stylesheet, resources.LOCAL_DIST if dist_url == resources.CDN_DIST else dist_url)

    mark(local, _isl_local=True)
    resources.patch_stylesheet = local
    reactive.patch_stylesheet = local


def tolerant_query_parser() -> None:
    """Panel parses the page's query when it makes ``pn.state.location`` and turns every all-digit value into an
    ``int``; Python refuses to convert more than 4300 digits (``ValueError``), so a link such as ``?seed=`` followed
    by 5000 digits failed the page's script before the dashboard's own parser (:mod:`app.urlsync`, which refuses the
    value in words) could read it, and the page stayed blank. Values Panel cannot convert stay text (the dashboard
    reads the raw query, never Panel's parsed one)."""
    from panel.io import location
    from panel.util import parse_query

    if getattr(location.parse_query, "_isl_tolerant", False):
        return

    def tolerant(query: str) -> dict:
        try:
            return parse_query(query)
        except ValueError:
            import urllib.parse as urlparse

            out = {}
            for key, text in urlparse.parse_qsl(query[1:]):
                try:
                    out.update(parse_query(f"?{urlparse.urlencode({key: text})}"))
                except ValueError:
                    out[key] = text
            return out

    mark(tolerant, _isl_tolerant=True)
    location.parse_query = tolerant


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


def handle_exception(exc: BaseException) -> None:
    """Log ``exc`` with its traceback under a new incident id; tell the user only that id."""
    incident = uuid.uuid4().hex[:8]
    log.error(
        "unhandled error in a dashboard callback [incident %s]", incident, exc_info=(type(exc), exc, exc.__traceback__)
    )
    try:
        notifications = pn.state.notifications
        if notifications is not None:
            notifications.error(USER_MESSAGE.format(incident=incident), duration=NOTIFICATION_MS)
    except Exception:  # the handler itself must never raise
        log.exception("could not notify the user of incident %s", incident)


def quiet_error_replies() -> None:
    """Make bokeh's websocket ``ERROR`` replies carry no traceback and no internal exception text (idempotent)."""
    from bokeh.protocol.messages.error import error

    if getattr(error.create, "_isl_quiet", False):
        return
    create = error.create.__func__

    def quiet_create(cls, request_id, text, **metadata):
        if not SAFE_ERROR_TEXT.match(text or ""):
            incident = uuid.uuid4().hex[:8]
            log.error("websocket ERROR reply withheld [incident %s]: %s", incident, text)
            text = ERROR_REPLY.format(incident=incident)
        message = create(cls, request_id, text, **metadata)
        message.content["traceback"] = None
        return message

    mark(quiet_create, _isl_quiet=True)
    error.create = classmethod(quiet_create)


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


_session_locks: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_session_locks_guard = threading.Lock()


def session_lock(doc) -> threading.RLock:
    """The lock under which a session's state is changed: held while one of its browser events is processed (on
    Panel's thread pool, :func:`serialize_session_events`) and while a job's outcome is applied on the event loop
    (:class:`app.page.SessionGate`). Sessions have one lock each, so they never wait for one another."""
    with _session_locks_guard:
        lock = _session_locks.get(doc)
        if lock is None:
            lock = _session_locks[doc] = threading.RLock()
        return lock


def _locked(doc):
    """:func:`session_lock` of ``doc``, or nothing to hold for an event outside a document (a notebook's comm)."""
    return session_lock(doc) if doc is not None else contextlib.nullcontext()


def serialize_session_events() -> None:
    """Process one session's browser events one at a time (idempotent).

    With ``--num-threads`` Panel processes each browser change on its thread pool, and two changes of one page on two
    threads at once: a slider sends ``value`` and ``value_throttled`` as two messages when it is released. Both
    threads then update the same widget with ``param.update``, whose batch flag is saved and restored around the
    update; interleaved, the flag stays set for good, and from then on the widget's watchers never run — the slider
    moves, the run does not (seen in ``benchmarks/bench_app_latency.py``: after 3 to 470 changes every further change
    of σ was lost, the page silent; the widget's ``param._BATCH_WATCH`` was True with 8 events queued). The same
    race can hit the dashboard's state, which every callback updates. Here each session's events (widget changes
    and UI events such as clicks) take :func:`session_lock` while they are processed: other sessions' still run in
    parallel.

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
        with _locked(doc):
            with queue_guard:
                events, self._events = self._events, {}
            with set_curdoc(doc):
                self._process_events(events)

    def serialized_bokeh_event(self, doc, *args, **kwargs):
        with _locked(doc):
            return bokeh_event(self, doc, *args, **kwargs)

    for fn in (guarded_server_change, serialized_change_event, serialized_bokeh_event):
        mark(fn, _isl_serialized=True)
    Syncable._server_change = guarded_server_change
    Syncable._change_event = serialized_change_event
    Syncable._process_bokeh_event = serialized_bokeh_event


def per_instance_readonly_edits() -> None:
    """Make Panel's ``edit_readonly`` lift the flags of the object's own parameters only (idempotent).

    To apply a browser change Panel sets every parameter of the widget to not read-only and not constant, and then
    back (``panel.util.parameters.edit_readonly``). A parameter the widget never copied is the class's object,
    shared by every session's widget of that class: two sessions' slider changes on two worker threads interleave
    there, the first restores ``constant`` while the second is setting ``value_throttled``, and the second fails with
    "Constant parameter 'value_throttled' cannot be modified" — that student's change is lost, with an incident
    notice (one change in one round of 20 pages under CPU load; the server log holds Panel's own traceback of it
    and the incident's). Here the object's read-only and constant
    parameters are copied to the instance first (param's own per-instance copy), so the flags that move are its own.
    """
    import sys

    from panel.util import parameters

    original = parameters.edit_readonly
    if getattr(original, "_isl_per_instance", False):
        return

    def edit_own_readonly(parameterized):
        for name, parameter in parameterized.param.objects("existing").items():
            if parameter.readonly or parameter.constant:
                parameterized.param[name]  # param copies the parameter to the instance on access
        return original(parameterized)

    mark(edit_own_readonly, _isl_per_instance=True, _isl_original=original)
    module: Any  # any module: it is patched only if it has Panel's edit_readonly
    for name, module in list(sys.modules.items()):  # the modules that imported it by name, and later importers
        if (name == "panel" or name.startswith("panel.")) and getattr(module, "edit_readonly", None) is original:
            module.edit_readonly = edit_own_readonly


def release_on_destroy(target: Any) -> None:
    """Release ``target`` when the current session is destroyed.

    ``target`` is a callable (called with no argument), an object with a ``release()`` method, or an object
    whose payload attributes (:data:`PAYLOAD_ATTRS`) are dropped. Outside a server session this does nothing.
    """
    doc = pn.state.curdoc
    context = getattr(doc, "session_context", None)
    if context is None:
        return
    key = context.id
    if key not in _releases:
        # bound to its key: Panel calls a discarded warm-up document's callbacks with None for the context
        doc.on_session_destroyed(_on_destroyed(key))
        _releases[key] = []
    _releases[key].append(_releaser(target))


def _on_destroyed(key: str) -> Callable[[Any], None]:
    def on_session_destroyed(session_context: Any) -> None:  # bokeh checks this exact signature
        release_session(session_context, key=key)

    return on_session_destroyed


def _releaser(target: Any) -> Callable[[], None]:
    if hasattr(target, "release") and callable(target.release):
        return target.release
    if callable(target):
        return target
    return lambda: drop_payloads(target)


def drop_payloads(obj: Any) -> None:
    """Drop the large payload attributes of ``obj``.

    Parameters go back to their defaults without firing watchers: the session's views are being torn down and
    must not redraw.
    """
    if isinstance(obj, param.Parameterized):
        names = [name for name in PAYLOAD_ATTRS if name in obj.param]
        with param.parameterized.discard_events(obj):
            obj.param.update(**{name: obj.param[name].default for name in names})
        return
    for name in PAYLOAD_ATTRS:
        if hasattr(obj, name) and not callable(getattr(obj, name)):
            setattr(obj, name, None)


def release_session(session_context: Any = None, *, key: str | None = None) -> None:
    """Run the release hooks of a destroyed session (``key``, else its context's id)."""
    key = key if key is not None else getattr(session_context, "id", None)
    if key is None:  # no session, no hooks
        return
    for release in _releases.pop(key, []):
        try:
            release()
        except Exception:
            log.exception("releasing a session's data failed")


def live_release_hooks() -> int:
    """Number of sessions with release hooks still pending (0 once every session is destroyed)."""
    return len(_releases)
