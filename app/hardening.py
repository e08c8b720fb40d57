"""Server-side hardening shared by every dashboard session.

What :func:`install` sets up (idempotent; :mod:`app.serve` calls it once in the server process before any
session exists, so it applies to every session; ``app/app.py`` may call it too, which makes a plain
``panel serve app/app.py`` just as safe):

* ``pn.config.exception_handler`` = :func:`handle_exception`: an exception escaping a widget or param
  callback is logged with its full traceback to the server log (logger ``isl.app``) under a short incident id,
  and the user sees a notification with that id and no traceback, no exception text, no file paths.
* ``pn.config.notifications = True``, so that every session has a place to show that message.
* one global ``pn.state.on_session_destroyed`` callback, :func:`release_session`: when the server destroys a
  session (its browser tab closed and ``--unused-session-lifetime`` elapsed), it runs the release hooks that the
  session registered with :func:`release_on_destroy`. A hook drops the session's large data (the latest
  ``Run``: a few (N+1)×m arrays, several MB on long runs) at once instead of leaving it to the cyclic garbage
  collector, which runs on object counts, not bytes.

Usage inside a session (e.g. in ``create_app()``)::

    state = AppState()
    hardening.release_on_destroy(state)      # calls state.release() if it has one, else drops known payloads
"""
from __future__ import annotations

import gc
import logging
import time
import uuid
from collections.abc import Callable
from typing import Any

import panel as pn
import param

log = logging.getLogger("isl.app")

USER_MESSAGE = ("Something went wrong while updating the dashboard (incident {incident}). "
                "The last good result is still shown; the server log has the details.")
NOTIFICATION_MS = 8000
# Outputs of app.state.AppState that hold a session's large data (the run's arrays, their display copies, the
# sweep's curves and points); on a param.Parameterized they are reset to their defaults.
PAYLOAD_ATTRS = ("run", "traces", "prediction", "curves", "points")
# At most one full garbage collection per this many seconds, however many sessions end at once.
GC_INTERVAL_S = 5.0

_installed = False
_releases: dict[str, list[Callable[[], None]]] = {}
_last_gc = 0.0


def install() -> None:
    """Install the exception handler, notifications and the session-release hook (idempotent)."""
    global _installed
    pn.config.exception_handler = handle_exception
    pn.config.notifications = True
    if _installed:
        return
    doc = pn.state.curdoc
    pn.state.on_session_destroyed(release_session)   # inside a session: that session only; else: every session
    _installed = doc is None


def handle_exception(exc: BaseException) -> None:
    """Log ``exc`` with its traceback under a new incident id; tell the user only that id."""
    incident = uuid.uuid4().hex[:8]
    log.error("unhandled error in a dashboard callback [incident %s]", incident,
              exc_info=(type(exc), exc, exc.__traceback__))
    try:
        notifications = pn.state.notifications
        if notifications is not None:
            notifications.error(USER_MESSAGE.format(incident=incident), duration=NOTIFICATION_MS)
    except Exception:  # the handler itself must never raise
        log.exception("could not notify the user of incident %s", incident)


def release_on_destroy(target: Any) -> None:
    """Release ``target`` when the current session is destroyed.

    ``target`` is a callable (called with no argument), an object with a ``release()`` method, or an object
    whose payload attributes (:data:`PAYLOAD_ATTRS`) are dropped. Outside a server session this does nothing.
    """
    doc = pn.state.curdoc
    context = getattr(doc, "session_context", None)
    if context is None:
        return
    _releases.setdefault(context.id, []).append(_releaser(target))


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


def release_session(session_context: Any) -> None:
    """Run the release hooks of a destroyed session, then (rate-limited) a full garbage collection."""
    for release in _releases.pop(getattr(session_context, "id", None), []):
        try:
            release()
        except Exception:
            log.exception("releasing a session's data failed")
    _collect_garbage()


def live_release_hooks() -> int:
    """Number of sessions with release hooks still pending (0 once every session is destroyed)."""
    return len(_releases)


def _collect_garbage() -> None:
    global _last_gc
    now = time.monotonic()
    if now - _last_gc >= GC_INTERVAL_S:
        _last_gc = now
        gc.collect()
