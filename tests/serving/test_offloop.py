"""The event loop's share of a page: what building pages on a thread relies on (bokeh's curdoc per thread, Panel's
link registry, callbacks scheduled from threads, outcomes applied while a page is built) and when the server collects
garbage (app.serving.offloop, app.serving.memory.MemoryTrimmer); the application that builds the pages there is
test_offloop_application.py's."""

from __future__ import annotations

import asyncio
import gc
import logging
import threading
import weakref
from functools import partial
from types import SimpleNamespace

import panel as pn
import pytest
from bokeh.document import Document
from bokeh.document.events import DocumentChangedEvent, SessionCallbackAdded
from bokeh.io.doc import curdoc, patch_curdoc
from panel.io.state import set_curdoc, state
from tornado.ioloop import IOLoop

from app.serving import offloop
from app.serving import session as serving_session
from app.serving.memory import QUIET_SESSIONS, MemoryTrimmer, freeze_warm_heap


def test_a_document_patched_on_one_thread_is_not_another_threads_curdoc():
    offloop.install()
    mine, theirs = Document(), Document()
    patched, checked = threading.Event(), threading.Event()
    seen = {}

    def other() -> None:
        with patch_curdoc(theirs):
            patched.set()
            checked.wait(10)
            seen["other"] = curdoc()

    worker = threading.Thread(target=other)
    worker.start()
    assert patched.wait(10)
    with patch_curdoc(mine):
        seen["main"] = curdoc()
        checked.set()
        worker.join(10)
        seen["main after"] = curdoc()
    assert seen["main"] is mine and seen["main after"] is mine and seen["other"] is theirs


def test_links_registered_while_the_loop_walks_the_registry_do_not_break_the_walk():
    """A part built on a thread registers its links (a button's ``js_on_click``) while the loop, attaching another
    page's part, walks Panel's link registry (``Link._process_callbacks``): the walk must finish. Interleaved here
    by hand: the walk is paused after its first entry while the registration happens."""
    from panel.links import Callback

    def register() -> pn.widgets.Button:
        button = pn.widgets.Button(label="b")
        button.js_on_click(code="1")
        return button

    kept = [register(), register()]
    offloop.install()
    assert isinstance(Callback.registry, offloop.SnapshotRegistry)
    plain = weakref.WeakKeyDictionary(Callback.registry)  # the dictionary Panel ships: the interleaving breaks it
    walk = iter(plain.values())
    next(walk)
    kept.append(register())
    plain[kept[-1]] = []
    with pytest.raises(RuntimeError, match="changed size during iteration"):
        list(walk)
    walk = iter(Callback.registry.values())  # the registry after install: the walk finishes
    next(walk)
    kept.append(register())
    rest = list(walk)
    assert len(rest) >= 1 and all(isinstance(links, list) for links in rest)
    assert all(b in Callback.registry for b in kept)  # every registration is kept ...
    gone = register()
    count = len(Callback.registry)
    del gone
    gc.collect()
    assert len(Callback.registry) == count - 1 and len(list(Callback.registry.items())) == count - 1  # ... weakly


class _Pausing(DocumentChangedEvent):
    """A held document event whose ``combine`` (bokeh asks every held event whether it absorbs a new one) pauses
    until released: a thread adding an event to the hold can be stopped halfway."""

    def __init__(self, doc) -> None:
        super().__init__(doc)
        self.entered, self.release = threading.Event(), threading.Event()

    def combine(self, event) -> bool:
        self.entered.set()
        self.release.wait(10)
        return False


def _served(doc, loop) -> None:
    """Give ``doc`` a session context as a server's, as far as scheduling looks (the loop that serves it)."""
    context = SimpleNamespace(server_context=SimpleNamespace(application_context=SimpleNamespace(io_loop=loop)))
    doc._session_context = lambda: context


def test_a_callback_scheduled_from_a_thread_is_registered_by_the_loop_and_never_lost():
    """A worker thread schedules a callback (a job's outcome) while the loop holds the document and then unholds it.
    Panel's ``execute`` registers it from the thread, into the hold: paused there while the loop unholds, the
    registration lands in the hold's old queue and is lost. After install, the thread only hands it to the loop."""
    offloop.install()
    panels_execute = type(state).execute._isl_original
    registered = []  # (event, thread) of every callback registration the document announces

    async def main() -> None:
        doc = Document()
        doc.on_change(
            lambda e: registered.append((e, threading.get_ident())) if isinstance(e, SessionCallbackAdded) else None
        )
        _served(doc, IOLoop.current())

        def schedule(execute, pausing=None) -> threading.Thread:
            doc.hold("combine")
            if pausing is not None:
                doc.callbacks._held_events.append(pausing)

            def work() -> None:
                with set_curdoc(doc):
                    execute(state, lambda: None, schedule=True)

            worker = threading.Thread(target=work)
            worker.start()
            return worker

        pausing = _Pausing(doc)  # Panel's execute: the thread pauses inside the hold, the loop unholds meanwhile
        worker = schedule(panels_execute, pausing)
        assert pausing.entered.wait(10)
        doc.unhold()
        pausing.release.set()
        worker.join(10)
        assert registered == [] and doc.callbacks._held_events == []  # lost: nothing will ever run it

        pausing = _Pausing(doc)  # after install: the thread does not touch the document
        schedule(type(state).execute, pausing).join(10)
        assert not pausing.entered.is_set() and doc.callbacks._held_events == [pausing]
        pausing.release.set()
        handed = asyncio.Event()  # the loop runs its callbacks in order: the thread's hand-over came before this one
        IOLoop.current().add_callback(handed.set)
        await handed.wait()  # the loop has registered it: in the hold, as any loop-side registration
        assert [type(e) for e in doc.callbacks._held_events] == [_Pausing, SessionCallbackAdded]
        doc.unhold()
        assert [thread for _, thread in registered] == [threading.get_ident()]  # announced, on the loop's thread

    asyncio.run(main())


class _Receiver:
    """Receives a document's events, as a server session does."""


def test_a_callback_for_a_session_destroyed_meanwhile_is_dropped_quietly(caplog):
    """An outcome on its way when its session ends reaches the loop after bokeh destroyed the document (and its
    callback manager): it is dropped, with no traceback in the server log (seen when a classroom run closed its
    sessions: "'DocumentCallbackManager' object has no attribute '_change_callbacks'")."""
    doc, session = Document(), _Receiver()
    doc.on_change_dispatch_to(session)
    doc.destroy(session)
    before = curdoc()
    with caplog.at_level(logging.DEBUG, logger=offloop.log.name):
        offloop._register(doc, lambda: None)
    assert [r.getMessage() for r in caplog.records] == ["dropped a callback of a destroyed session"]
    assert curdoc() is before  # the destroyed document is not left as this thread's curdoc (a later export failed)


def test_outcomes_that_arrive_while_the_page_is_built_go_out_with_it(monkeypatch):
    """A job's outcome (the first run) that arrives while the page is built is applied on the building thread by
    ``apply_here``, before any browser has the page; once the page is connected, ``apply_here`` does nothing."""
    from app.page import SessionGate

    sent: list = []
    monkeypatch.setattr(pn.state, "execute", lambda fn, schedule=False: sent.append(fn))
    doc, applied = Document(), []
    gate = SessionGate(doc)
    worker = threading.Thread(target=gate.schedule, args=(lambda: applied.append((1, state.curdoc)),))
    worker.start()
    worker.join()
    gate.apply_here()
    assert applied == [(1, doc)] and sent == []  # applied here, with the page's document current
    gate.opened()
    gate.schedule(lambda: applied.append(2))
    gate.apply_here()
    assert [a for a, *_ in applied] == [1] and len(sent) == 1  # later outcomes go to the loop, as before


def test_an_applied_outcome_is_not_kept_by_the_loops_callback(monkeypatch):
    """bokeh's one-shot callback and its wrapper hold each other in a reference cycle, and hold the function the
    gate hands to the loop: that function must let go of the outcome once applied, or a whole run's traces stay
    until a full garbage collection (a heavy session's server grew ≈ 1.4 MB a run, 480 MB → 1.46 GB in 5 min)."""
    from app.page import SessionGate

    class Outcome:  # a run's result: what the callback must not keep
        pass

    sent: list = []
    monkeypatch.setattr(pn.state, "execute", lambda fn, schedule=False: sent.append(fn))
    gate, applied = SessionGate(Document()), []
    gate.opened()
    outcome = Outcome()
    gate.schedule(partial(applied.append, outcome))
    alive = weakref.ref(outcome)
    del outcome
    gc.disable()  # freed by reference counting alone, as in the served app (memory.young_then_freeze)
    try:
        sent[0]()
        assert len(applied) == 1 and alive() is applied[0]
        applied.clear()
        assert alive() is None, "the loop's callback still holds the outcome"
        sent[0]()  # a second call (none is expected) applies nothing
        assert applied == []
    finally:
        gc.enable()


def test_prebuilt_models_are_the_ones_panel_attaches():
    doc = Document()
    container = pn.Column()
    root = container.get_root(doc)
    state._views[root.ref["id"]] = (container, root, doc, None)
    doc._session_context = lambda: object()  # as in a server session
    try:
        part = pn.Row(pn.pane.Markdown("a part"))
        serving_session.prebuild(part, container)
        prebuilt = part._models[root.ref["id"]][0]
        with set_curdoc(doc):  # as Panel applies it on the session's loop
            container.objects = [part]
        assert root.children == [prebuilt]
    finally:
        del state._views[root.ref["id"]]


class _Server:
    def __init__(self) -> None:
        self.sessions: list = []

    def get_sessions(self) -> list:
        return self.sessions


def test_full_collections_wait_until_the_class_has_left(monkeypatch):
    collected = []
    monkeypatch.setattr(gc, "collect", lambda *a: collected.append(a) or 0)
    monkeypatch.setattr(gc, "freeze", lambda: collected.append("freeze"))
    monkeypatch.setattr(gc, "unfreeze", lambda: collected.append("unfreeze"))
    full = lambda: [a for a in collected if a in ((), (2,))]  # noqa: E731
    server = _Server()
    trimmer = MemoryTrimmer(server)
    server.sessions = [object()] * 40
    trimmer()
    assert collected == [(1,), "freeze"]  # nothing ended: the young ones, then a freeze
    collected.clear()
    server.sessions = server.sessions[:39]  # a student closed a tab: no full collection in class
    trimmer()
    assert collected == [(1,), "freeze"]  # the same: Panel's own collection after it then walks only what is new
    collected.clear()
    server.sessions = server.sessions[:QUIET_SESSIONS]
    trimmer()
    assert collected == ["unfreeze", (), "freeze"]  # the class has left: everything, frozen or not
    collected.clear()
    trimmer()  # nothing ended since: the young generations only
    assert full() == []


def test_memory_is_trimmed_again_once_the_ended_sessions_release_hooks_have_run(monkeypatch, caplog):
    trims = []
    pending = [0]
    monkeypatch.setattr(serving_session, "live_release_hooks", lambda: pending[0])
    monkeypatch.setattr(gc, "collect", lambda *a: 0)
    server = _Server()
    trimmer = MemoryTrimmer(server)
    trimmer._trim = lambda pad: trims.append(pad)
    server.sessions = [object()] * 3
    trimmer()
    with caplog.at_level("INFO", logger="isl.serve"):
        server.sessions, pending[0] = [], 3  # the sessions ended; their results are not released yet: nothing freed
        trimmer()
        assert trims == []
        pending[0] = 1  # two released: their memory is handed back
        trimmer()
        assert len(trims) == 1
        trimmer()  # nothing changed: nothing to trim
        assert len(trims) == 1
        pending[0] = 0  # the last one: handed back too, and the line says nothing is left
        trimmer()
    assert len(trims) == 2
    lines = [r.getMessage() for r in caplog.records if r.getMessage().startswith("isl trim:")]
    assert [line.split(" collected")[0] for line in lines] == [
        "isl trim: sessions=0 pending_releases=1",
        "isl trim: sessions=0 pending_releases=0",
    ]


def test_panels_collection_after_a_session_walks_only_what_is_newer_than_the_last_freeze():
    """Panel runs ``gc.collect()`` after every session's end (its own, not replaced); what lived before the warm
    heap was frozen is not walked by it, only what was made since (``gc.get_objects`` lists what a full collection
    walks: the frozen objects are not in it)."""
    import panel.io.document as panel_document

    assert panel_document._garbage_collect.__module__ == "panel.io.document"
    try:
        freeze_warm_heap()
        frozen = gc.get_freeze_count()
        made = [[i] for i in range(1000)]  # (lists: tracked by the collector)
        walked = len(gc.get_objects())
        assert len(made) <= walked < frozen / 10, (walked, frozen)
    finally:
        gc.unfreeze()  # this test process keeps its objects collectable


def test_the_server_says_which_allocator_it_runs_with(monkeypatch, caplog):
    from app.serving.memory import ALLOCATOR_ENV, check_allocator

    name, value = ALLOCATOR_ENV
    with caplog.at_level("INFO", logger="isl.serve"):
        monkeypatch.setenv(name, value)
        assert check_allocator()
        monkeypatch.delenv(name)
        assert not check_allocator()
    lines = [r.getMessage() for r in caplog.records if r.getMessage().startswith("memory:")]
    assert "goes back" in lines[0] and "stays for the next one" in lines[1]
