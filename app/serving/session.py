"""What a dashboard session's own code uses from the server: its lock, its release hooks, its error notice, and
where its page is being built. Nothing here replaces library code: the patches of Panel and Bokeh live in
:mod:`app.serving.patches` and its modules, installed once by the server's start-up.

* :func:`session_lock` — the lock under which one session's state changes (browser events and job outcomes);
* :func:`release_on_destroy` — drop a session's large data as soon as the server destroys the session;
* :func:`handle_exception` — Panel's ``exception_handler``: the traceback to the log, an incident id to the user;
* :func:`building_page`, :func:`prebuild`, :func:`session_loop` — the page built on the server's page thread
  (:class:`app.serving.offloop.OffLoopApplication`), parts' models built before they are swapped in, and the loop
  that serves a session;
* :func:`settle_markup_stylesheets` — markup panes' stylesheets as their first update would send them;
* :func:`serve_panel_files` — every stylesheet of the page served by the server itself, none by Panel's CDN;
* :func:`page_location` — the page's ``Location`` (its URL), one whose query Panel's parser cannot fail on.

Usage inside a session (e.g. in ``create_app()``)::

    state = AppState()
    session.release_on_destroy(state.close)   # or an object: its release(), else its payload attributes
"""

from __future__ import annotations

import contextlib
import logging
import threading
import urllib.parse
import uuid
import weakref
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import panel as pn
import param
from panel.io.location import Location
from panel.util import parse_query

from app.jobs.base import PAGE_NICE, lower_priority

__all__ = [
    "PAGE_POOL",
    "PageLocation",
    "building_page",
    "handle_exception",
    "live_release_hooks",
    "locked",
    "page_location",
    "prebuild",
    "release_on_destroy",
    "release_session",
    "serve_panel_files",
    "session_lock",
    "session_loop",
    "settle_markup_stylesheets",
]

log = logging.getLogger("isl.app")

USER_MESSAGE = (
    "Something went wrong while updating the dashboard (incident {incident}). "
    "The last good result is still shown; the server log has the details."
)
NOTIFICATION_MS = 8000
# Outputs of app.state.AppState that hold a session's large data (the run's arrays, their display copies, the
# sweep's curves and points); on a param.Parameterized they are reset to their defaults.
PAYLOAD_ATTRS = ("run", "traces", "prediction", "curves", "points")
PAGE_THREAD = "isl-page"
#: the one thread that runs the app script for new sessions (:class:`app.serving.offloop.OffLoopApplication`)
PAGE_POOL = ThreadPoolExecutor(max_workers=1, thread_name_prefix=PAGE_THREAD, initializer=lower_priority(PAGE_NICE))

_releases: dict[str, list[Callable[[], None]]] = {}
_session_locks: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_session_locks_guard = threading.Lock()


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


def session_lock(doc) -> threading.RLock:
    """The lock under which a session's state is changed: held while one of its browser events is processed (on
    Panel's thread pool, :func:`app.serving.hardening.serialize_session_events`) and while a job's outcome is applied
    on the event loop (:class:`app.page.SessionGate`). Sessions have one lock each, so they never wait for one
    another."""
    with _session_locks_guard:
        lock = _session_locks.get(doc)
        if lock is None:
            lock = _session_locks[doc] = threading.RLock()
        return lock


def locked(doc):
    """:func:`session_lock` of ``doc``, or nothing to hold for an event outside a document (a notebook's comm)."""
    return session_lock(doc) if doc is not None else contextlib.nullcontext()


def release_on_destroy(target: Any) -> None:
    """Release ``target`` when the current session is destroyed.

    When the server destroys the session (its tab closed and ``--unused-session-lifetime`` elapsed) — or Panel
    discards its warm-up session — the hook drops the session's large data (the latest ``Run``: a few (N+1)×m arrays,
    several MB on long runs) at once, even if something still holds the session's objects. ``target`` is a callable
    (called with no argument), an object with a ``release()`` method, or an object whose payload attributes
    (:data:`PAYLOAD_ATTRS`) are dropped. Outside a server session this does nothing.
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


def session_loop(doc):
    """The tornado ``IOLoop`` serving ``doc``'s session; None outside a served session."""
    context = getattr(doc, "session_context", None)
    server = getattr(context, "server_context", None)
    return getattr(getattr(server, "application_context", None), "io_loop", None)


def building_page() -> bool:
    """This thread is :data:`PAGE_POOL`'s, building a new session's page."""
    return threading.current_thread().name.startswith(PAGE_THREAD)


def prebuild(obj, container) -> None:
    """Build ``obj``'s bokeh models for every page root ``container`` is shown in, where ``obj`` will become
    ``container``'s child; models built here are not attached to any document until Panel swaps ``obj`` in on the
    event loop (it then reuses them: Panel reuses a component's models when it already has them for the page's
    root, so the event loop only attaches them instead of building them). Outside a server session there is nothing
    to do."""
    from panel.io.state import state

    for ref, (model, _) in list(container._models.items()):
        view = state._views.get(ref)
        if view is None or view[3] is not None:  # no longer shown, or a notebook comm: leave it to Panel
            continue
        _, root, doc, _ = view
        if doc is None or doc.session_context is None or ref in obj._models:
            continue
        obj._get_model(doc, root, model, None)


def settle_markup_stylesheets(doc) -> None:
    """Give the model of every markup pane shown in ``doc`` the stylesheets its first update would send; one walk of
    the page's models for all of them. Nothing without a document.

    Panel builds a markup pane's model (HTML, Markdown, Alert) with the stylesheets its template's design applies,
    and updates it with those of ``_get_properties``, which also hold the theme's base sheet (``default.css``). So the
    first update of each such pane changed its ``stylesheets``, a list of models, and bokeh re-walked every model of
    the page at a session's first slider change (:ref:`performance-page-building`). Given here while the page is
    built, the first update changes nothing there."""
    from panel.io.state import state
    from panel.pane.markup import HTMLBasePane

    if doc is None:
        return
    roots = [view for view, _, shown, _ in list(state._views.values()) if shown is doc and hasattr(view, "select")]
    with doc.models.freeze():
        for pane in {id(p): p for root in roots for p in root.select(HTMLBasePane)}.values():
            for model, _ in list(pane._models.values()):
                if model.document is doc:
                    sheets = pane._get_properties(doc).get("stylesheets")
                    if sheets is not None and sheets != model.stylesheets:
                        model.stylesheets = sheets


def serve_panel_files(doc) -> None:
    """Make every stylesheet Panel builds for ``doc`` point at the server's own copy of Panel's files (nothing
    without a document); called before the page is built.

    Panel points a component's stylesheets at its document's ``dist_url`` template variable and, where the document
    has none, at its CDN (cdn.holoviz.org): a classroom without internet then waits on a request that fails. Panel
    sets that variable when it renders the page's HTML — after the app script has built the page, and never for the
    warm-up's document or a session's page, whose HTML is a start-up page's (:mod:`app.serving.pages`). Set here
    first, through bokeh's public ``Document.template_variables``, to Panel's ``static/extensions/panel/`` under the
    page's relative path.

    Without a relative path that is ``./static/extensions/panel/`` (the same address from the page), not
    ``static/…``: Panel also updates stylesheets for a document it cannot name — a part whose models are outside the
    page (:class:`app.page.LocalFast`) — pointing them at its CDN, and it moves an address that starts with
    ``static/`` there, but leaves one that starts with ``./`` or ``../`` as it is (as behind a URL prefix). The page's
    stylesheet models are shared by its components, so one such update pointed every ``loading.css`` of the page at
    the CDN."""
    if doc is None:
        return
    from panel.io.resources import LOCAL_DIST

    doc.template_variables.setdefault("dist_url", f"{pn.state.rel_path or '.'}/{LOCAL_DIST}")


_locations: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class PageLocation(Location):
    """Panel's ``Location`` (the browser's URL, synced both ways) whose :attr:`query_params` keeps as text a value
    Panel's parser cannot convert, rather than raising.

    Panel parses the query into typed values whenever the ``search`` of a ``Location`` changes — when it is made
    from the request, and when the page reports the URL it was opened with — and turns every all-digit value into an
    ``int``, which Python refuses beyond 4300 digits (``ValueError``): a link such as ``?seed=`` followed by 5000
    digits failed the page's script before the dashboard's own parser (:mod:`app.urlsync`, which refuses the value
    in words and reads the raw ``search``, never ``query_params``) could read it, and the page stayed blank."""

    @property
    def query_params(self) -> dict[str, Any]:
        try:
            return parse_query(self.search)
        except ValueError:
            out: dict[str, Any] = {}
            for key, text in urllib.parse.parse_qsl(self.search[1:]):
                try:
                    out.update(parse_query(f"?{urllib.parse.urlencode({key: text})}"))
                except ValueError:
                    out[key] = text
            return out


def page_location(doc) -> Location | None:
    """The :class:`PageLocation` of ``doc``'s served page, made from its request as Panel makes its own, the same
    object at every call; the page's template is given it (``servable(location=...)``, Panel's public argument), so
    Panel never makes its own. Outside a served session, Panel's ``pn.state.location``.

    The location is forgotten when the session ends. A weak key alone would never let the document go: the location
    is watched by the page's URL sync, which holds the page's state, its jobs and, through them, the document — the
    value keeps its own key alive, and every closed session's page stayed in memory with it
    (:ref:`performance-memory-release`)."""
    if doc is None or doc.session_context is None:
        return pn.state.location
    location = _locations.get(doc)
    if location is None:
        location = _locations[doc] = PageLocation.from_request(doc.session_context.request)
        doc.on_session_destroyed(_forget_location(weakref.ref(doc)))
    return location


def _forget_location(doc_ref: weakref.ref) -> Callable[[Any], None]:
    def on_session_destroyed(session_context: Any) -> None:  # bokeh checks this exact signature
        doc = doc_ref()  # (a weak reference: the document's own callback must not hold it)
        if doc is not None:
            _locations.pop(doc, None)

    return on_session_destroyed
