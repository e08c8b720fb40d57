"""The application the server serves (app.serving.offloop.OffLoopApplication): each session's page built once, on
the page thread, with every duty of Panel's and bokeh's own document building; handed to the server by the serve
command's public hook, with no library code replaced."""

from __future__ import annotations

import argparse
import asyncio
import logging
import threading

import panel as pn
import pytest
from bokeh.application import Application
from bokeh.application.handlers import FunctionHandler
from bokeh.command.util import build_single_handler_application
from bokeh.document import Document
from bokeh.server.contexts import ApplicationContext
from panel.io.state import state
from tornado.httputil import HTTPHeaders, HTTPServerRequest, RequestStartLine

from app.serving import offloop, serve
from app.serving.warmup import AppStartupError, raise_if_failed


def _create(application, *session_ids: str):
    """The sessions bokeh's server creates for ``session_ids`` (asked for at once, by a browser's request with no
    query) on a fresh loop, and that loop's thread (name, ident)."""
    request = HTTPServerRequest(
        start_line=RequestStartLine("GET", "/app", "HTTP/1.1"), headers=HTTPHeaders({"Host": "127.0.0.1"})
    )

    async def create():
        context = ApplicationContext(application, url="/app")
        sessions = await asyncio.gather(*(context.create_session_if_needed(i, request) for i in session_ids))
        return sessions, threading.current_thread().name, threading.get_ident()

    return asyncio.run(create())


def test_a_new_sessions_page_is_built_once_on_the_page_thread_and_then_belongs_to_the_loop(monkeypatch):
    """The session hooks run on the loop first; the app script and bokeh's validation of the document run once, on
    the page thread (a second request for the session waits for the same build); the document then belongs to the
    loop."""
    built_on, hooks_on, validated_on = [], [], []

    class Hooked(FunctionHandler):
        async def on_session_created(self, session_context) -> None:
            hooks_on.append((threading.current_thread().name, len(built_on)))

    def page(doc) -> None:
        built_on.append(threading.current_thread().name)
        doc.add_root(pn.pane.Markdown("built").get_root(doc))

    validate = Document.validate
    monkeypatch.setattr(
        Document, "validate", lambda doc: validated_on.append(threading.current_thread().name) or validate(doc)
    )
    application = offloop.OffLoopApplication.like(Application(Hooked(page)))
    (first, again), loop_name, loop_ident = _create(application, "a-session-id", "a-session-id")
    assert first is again
    assert hooks_on == [(loop_name, 0)]  # before the build, on the loop
    assert built_on == ["isl-page_0"] and validated_on == ["isl-page_0"]  # once each, on the page thread
    assert len(first.document.roots) == 1
    assert state._thread_id_[first.document] == loop_ident


def test_a_page_built_outside_a_sessions_creation_is_built_where_it_is_asked():
    """The start-up pages (app.serving.pages) are built by ``initialize_document`` itself, on the caller's thread."""
    built_on = []
    application = offloop.OffLoopApplication.like(
        Application(FunctionHandler(lambda doc: built_on.append(threading.current_thread().name)))
    )
    application.create_document()
    assert built_on == [threading.current_thread().name]


def test_a_script_that_fails_at_a_session_is_reported_as_before(tmp_path, caplog):
    """The script's failure is its handler's, seen through the served application (the start-up's check), and
    bokeh's error line is logged once for the session, from the page thread's build."""
    script = tmp_path / "app.py"
    script.write_text(
        "import panel as pn\nif pn.state.curdoc.session_context.id == 'broken':\n    raise RuntimeError('on purpose')\n"
        "pn.pane.Markdown('fine').servable()\n"
    )
    application = offloop.OffLoopApplication.like(build_single_handler_application(str(script)))
    (fine,), _, _ = _create(application, "fine")
    raise_if_failed([application])
    assert fine.document.roots
    with caplog.at_level(logging.ERROR, logger="bokeh.application.application"):
        (broken,), _, _ = _create(application, "broken")
    assert [r.threadName for r in caplog.records if "on purpose" in r.getMessage()] == ["isl-page_0"]
    assert not broken.document.roots
    with pytest.raises(AppStartupError, match="on purpose"):
        raise_if_failed([application])


def test_the_serve_command_serves_off_loop_applications_with_the_scripts_handlers(tmp_path):
    """bokeh's ``customize_applications`` hands the server one OffLoopApplication per application Panel built (its
    index route and the page's route share it), with the script's handlers; no method of it is replaced."""
    script = tmp_path / "app.py"
    script.write_text("import panel as pn\npn.pane.Markdown('x').servable()\n")
    built = build_single_handler_application(str(script))
    command = serve._serve_command(["localhost:5006"], 0)(parser=argparse.ArgumentParser())
    served = command.customize_applications(argparse.Namespace(index="app.py"), {"/app": built})
    assert set(served) == {"/", "/app"} and served["/"] is served["/app"]
    assert type(served["/app"]) is offloop.OffLoopApplication and served["/app"].handlers == built.handlers
    assert not {"on_session_created", "initialize_document"} & set(vars(served["/app"]))


def test_the_dashboards_shown_parts_are_built_with_the_page_not_swapped_in_on_the_loop(monkeypatch):
    """The dashboard's page, built off the loop as the server builds it: its controls and the trajectories' plots
    are in the document the browser pulls (not placeholders that the loop fills in later, re-walking every model of
    the page for each part), and the hidden tabs are left for when they are opened."""
    from bokeh.document.models import DocumentModelManager
    from bokeh.models import ColumnDataSource, Slider

    from app.serving.serve import app_script

    walks: list[str] = []  # the thread of every walk of a document's models
    recompute = DocumentModelManager.recompute
    monkeypatch.setattr(
        DocumentModelManager, "recompute", lambda self: walks.append(threading.current_thread().name) or recompute(self)
    )
    application = offloop.OffLoopApplication.like(build_single_handler_application(app_script()))
    (session,), loop_thread, _ = _create(application, "a-page")
    doc = session.document
    sliders = [m.title for m in doc.models if isinstance(m, Slider)]
    assert any("σ" in title for title in sliders), sliders  # the controls
    assert doc.get_model_by_name("traj-1-isl") is not None  # the plots of Fig. 3
    assert doc.get_model_by_name("traj-1-isl").__class__ is ColumnDataSource
    assert walks and loop_thread not in walks  # the page's models were walked on the page thread only
    assert not any(m.name and m.name.startswith("sweep-") for m in doc.models)  # a hidden tab: not built yet
