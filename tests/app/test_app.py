"""The page assembly (app.app): a session's job outcomes wait until its page is connected."""

from __future__ import annotations

import threading

import panel as pn
from bokeh.document import Document
from panel.io.state import set_curdoc

from app.app import SessionGate


def test_outcomes_wait_for_the_page_then_apply_in_order(monkeypatch):
    """Panel drops changes made to a document before its session is connected (the browser may already hold the
    serialized page): outcomes scheduled then are queued, and applied in order by ``opened`` (Panel's onload)."""
    applied, sent = [], []
    monkeypatch.setattr(pn.state, "execute", lambda fn, schedule=False: sent.append(fn))
    doc = Document()
    gate = SessionGate(doc)
    workers = [threading.Thread(target=gate.schedule, args=(lambda k=k: applied.append(k),)) for k in range(3)]
    for w in workers:
        w.start()
        w.join()  # in order, from other threads, as job outcomes arrive
    assert sent == []  # nothing reached the loop before the page loaded
    gate.opened()
    gate.schedule(lambda: applied.append(3))  # after onload: at once
    with set_curdoc(doc):
        for fn in sent:
            fn()
    assert applied == [0, 1, 2, 3]


def test_sessions_share_the_servers_one_long_job_queue():
    """The server runs app/app.py anew for each session: what must exist once (the long-job queue and its thread)
    lives in the module app.page. (A queue made by the script itself was one per session — two sessions' long jobs
    ran at once, and each queue's thread kept its closed session's namespace alive.)"""
    import threading

    from bokeh.command.util import build_single_handler_application
    from panel.io.session import generate_session

    from app.page import LONG_JOBS
    from app.serving.serve import app_script

    def queue_threads() -> int:
        return sum(t.name.startswith("isl-long") for t in threading.enumerate())

    before = queue_threads()  # the server's one queue (and any a test made itself)
    application = build_single_handler_application(app_script())
    docs = [generate_session(application).document for _ in range(3)]
    assert len(docs) == 3 and all(d.roots for d in docs)
    assert queue_threads() == before >= 1 and LONG_JOBS.processes
