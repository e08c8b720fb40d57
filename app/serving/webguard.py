"""What the dashboard's web server adds to every answer: security headers, a host check, compression, /liveness.

Installed on the Tornado application of a served dashboard by :func:`install` (``app.serving.serve`` calls it from
Panel's ``customize_server`` hook):

* **Framing**: ``Content-Security-Policy: frame-ancestors 'self'`` and ``X-Frame-Options: SAMEORIGIN`` — no other
  site can show the dashboard in a frame (and open sessions through its visitors' browsers). A course page that
  should embed it is named by ``--frame-ancestors`` / ``ISL_FRAME_ANCESTORS`` (e.g. ``https://lms.example.edu``):
  the policy becomes ``frame-ancestors 'self' https://lms.example.edu`` and ``X-Frame-Options`` is left out (it
  cannot name another site; browsers that know CSP, i.e. all current ones, follow the policy).
* ``X-Content-Type-Options: nosniff`` and ``Referrer-Policy: same-origin``.
* **Hosts**: a request whose ``Host`` header is not one of the allowed origins (``ISL_ALLOWED_ORIGINS``, the same
  list as the websocket's, with bokeh's wildcards) is refused with 403 before any handler runs — a page of another
  name (DNS rebinding) cannot open sessions. ``/liveness`` answers whatever the host (orchestrators probe by IP).
* **Compression**: text, JavaScript, JSON and CSS answers are gzip-compressed for clients that accept it (the page's
  2 MB of scripts travel as ≈ 0.5 MB).
* ``GET /liveness``: 200 with ``{"alive": true}`` as long as the event loop answers — nothing else is done: Panel's
  own handler builds a whole session when asked with ``?endpoint=/app`` (seconds of the event loop).
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import tornado.web
import tornado.websocket
from bokeh.server.util import match_host

__all__ = ["LIVENESS_PATH", "check_frame_ancestors", "frame_policy", "install"]

LIVENESS_PATH = "/liveness"
_SOURCE = re.compile(r"^(?:'self'|'none'|https?://(?:\*\.)?[A-Za-z0-9.-]+(?::\d{1,5})?)$")


def check_frame_ancestors(spec: str | None) -> list[str]:
    """The extra frame ancestors of ``spec`` (space- or comma-separated CSP sources: ``https://lms.example.edu``),
    or ``ValueError`` naming the setting and an example. A bare ``*`` (any site) is refused."""
    sources = [s for s in re.split(r"[\s,]+", spec or "") if s]
    for s in sources:
        if not _SOURCE.match(s):
            raise ValueError(
                f"--frame-ancestors / ISL_FRAME_ANCESTORS must list sites like https://lms.example.edu "
                f"(scheme://host[:port], a leading *. allowed), got {s!r}"
            )
    return list(dict.fromkeys(s for s in sources if s != "'self'"))


def frame_policy(ancestors: Sequence[str]) -> dict[str, str]:
    """The framing and related headers for these extra frame ancestors (module docstring)."""
    headers = {
        "Content-Security-Policy": "frame-ancestors " + " ".join(["'self'", *ancestors]),
        "X-Content-Type-Options": "nosniff",
        "Referrer-Policy": "same-origin",
    }
    if not ancestors:
        headers["X-Frame-Options"] = "SAMEORIGIN"
    return headers


class _Liveness(tornado.web.RequestHandler):
    def get(self) -> None:
        self.set_header("Cache-Control", "no-store")
        self.write({"alive": True})


class _ForbiddenHost(tornado.web.RequestHandler):
    def prepare(self) -> None:
        self.set_status(403)
        self.set_header("Content-Type", "text/plain; charset=utf-8")
        self.finish("403: this server does not answer to that host name (see ISL_ALLOWED_ORIGINS)\n")


def install(application: tornado.web.Application, origins: Sequence[str], ancestors: Sequence[str]) -> None:
    """Add the headers, the host check, compression and ``/liveness`` to a Tornado ``application``."""
    headers = frame_policy(ancestors)

    class SecurityHeaders(tornado.web.OutputTransform):
        def transform_first_chunk(self, status_code, response_headers, chunk, finishing):
            for name, value in headers.items():
                response_headers[name] = value
            return status_code, response_headers, chunk

    application.transforms.insert(0, SecurityHeaders)
    if tornado.web.GZipContentEncoding not in application.transforms:
        application.transforms.append(tornado.web.GZipContentEncoding)
    application.wildcard_router.rules.insert(
        0, tornado.routing.Rule(tornado.routing.PathMatches(re.escape(LIVENESS_PATH) + "$"), _Liveness)
    )
    find = application.find_handler

    def find_handler(request, **kwargs):
        host = request.host or ""
        if request.path != LIVENESS_PATH and not any(match_host(host, pattern) for pattern in origins):
            return application.get_handler_delegate(request, _ForbiddenHost)
        return find(request, **kwargs)

    application.find_handler = find_handler  # type: ignore[method-assign]  # Tornado has no hook before routing
    for rule in application.wildcard_router.rules:
        if isinstance(rule.target, type) and issubclass(rule.target, tornado.websocket.WebSocketHandler):
            rule.target = _no_delay(rule.target)


def _no_delay(handler: type) -> type:
    """``handler`` (bokeh's websocket handler) with Nagle's algorithm off once a connection is open.

    bokeh sends each message as several websocket frames (header, metadata, content, buffers), each its own small
    write. With Nagle's algorithm on — tornado's default — a frame that follows an unacknowledged one waits for the
    client's acknowledgement, which a client's TCP may delay (delayed acknowledgements). It is for clients that
    acknowledge late, such as scripts and some proxies; chromium acknowledges at once (:ref:`performance-choices`)."""

    class NoDelay(handler):
        def open(self, *args, **kwargs):
            result = super().open(*args, **kwargs)
            if self.ws_connection is not None:
                self.set_nodelay(True)
            return result

    NoDelay.__name__ = NoDelay.__qualname__ = f"NoDelay{handler.__name__}"
    return NoDelay
