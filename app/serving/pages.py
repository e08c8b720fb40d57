"""The pages a server process answers HTML requests from (Panel's ``--reuse-sessions``).

A page's HTML names its parts by their order, the template around them and its variables; the session's own page,
with the link's settings, is built when its websocket connects (:ref:`serving-cores`). Of the link's inputs only
presenter mode (``present``) changes that HTML itself (the sidebar folded away, the larger text's style sheet), so
each process builds two pages at start-up, one without and one with it, and answers each request from the one its
``present`` spells: a bounded set, so no link can make the server keep another page.
"""

from __future__ import annotations

__all__ = ["build_pages", "page_key"]

PRESENT = "present"  #: the one link input that changes the page's HTML


def page_key(request) -> tuple[str, bool]:
    """Which start-up page answers ``request`` (a tornado request): its path, and whether its link asks for presenter
    mode as the page reads it (the last ``present``, a switch; a value that is not one reads as off)."""
    from app.inputs import parse_text
    from app.state import declaration

    values = request.arguments.get(PRESENT) or [b""]
    try:
        present = parse_text(values[-1].decode("utf-8", "replace"), declaration(PRESENT)) is True
    except ValueError:
        present = False
    return request.path.rstrip("/") or "/", present  # "/app/" is "/app": bokeh routes both to the page


def build_pages(applications: dict) -> None:
    """Build the start-up pages of every ``{path: application}`` for :func:`page_key` and make Panel answer from them
    (in each server process, before it serves; raises :class:`app.serving.warmup.AppStartupError` if the app fails)."""
    from panel.io.document import _cleanup_doc
    from panel.io.session import generate_session
    from panel.io.state import set_curdoc, state
    from tornado.httputil import HTTPHeaders, HTTPServerRequest, RequestStartLine

    from app.serving.warmup import raise_if_failed
    from app.state import declaration

    for path, application in applications.items():
        state._sessions.pop(path, None)  # Panel's warm-up page: keyed by the path alone
        for present in (False, True):
            uri = f"{path}?{PRESENT}=1" if present else path
            request = HTTPServerRequest(
                start_line=RequestStartLine("GET", uri, "HTTP/1.1"), headers=HTTPHeaders({"Host": "localhost"})
            )
            # A page built outside a connection does not see its request's query (Panel's location of such a page
            # is empty): presenter mode is this page's default while it is built, as the link would set it.
            default, declaration(PRESENT).default = declaration(PRESENT).default, present
            try:
                session = generate_session(application, request=request, payload={"arguments": request.arguments})
            finally:
                declaration(PRESENT).default = default
            raise_if_failed([application])
            with set_curdoc(session.document):
                state._sessions[(path, present)] = session
                session.block_expiration()
                state._on_load(None)
            _cleanup_doc(session.document, destroy=False)
        # both of bokeh's routes to the page (``/app/?``): a path Panel has no key function for gets one of its own,
        # keyed by the link's theme, and a new kept session for every theme a link names
        for route in {path, path.rstrip("/") + "/"}:
            state._session_key_funcs[route] = page_key
