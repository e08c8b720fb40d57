"""One page's browser events are processed one at a time (app.serving.hardening.serialize_session_events).

With ``--num-threads`` Panel processes each browser message on its thread pool; a released slider's two messages
(``value``, ``value_throttled``) then ran on two threads at once, and the slider could stop moving the run for good.
"""

from __future__ import annotations

import sys
import threading

import panel as pn
import pytest
from bokeh.document import Document
from bokeh.events import ButtonClick
from bokeh.models import Button

from app.serving import hardening


@pytest.mark.parametrize(
    "entry, inner, args",
    [("_change_event", "_process_events", ()), ("_process_bokeh_event", "_process_event", (ButtonClick(Button()),))],
)
def test_one_pages_browser_events_are_processed_one_at_a_time(entry, inner, args):
    """A released slider sends ``value`` and ``value_throttled`` as two messages, which Panel processed on two threads
    at once: param's batch flag of the widget then stayed set and the slider stopped moving the run (seen after 3 to
    470 changes). A second event of the same page now waits until the first is processed; another page's does not."""
    hardening.install()
    page, other = Document(), Document()
    release = threading.Event()
    entered = {name: threading.Event() for name in ("first", "second", "other page")}

    def widget(name: str, block: bool = False):
        w = pn.widgets.FloatSlider()

        def process(*_):
            entered[name].set()
            if block:
                assert release.wait(30)

        setattr(w, inner, process)
        return w

    def event(name: str, doc: Document, block: bool = False) -> threading.Thread:
        thread = threading.Thread(target=getattr(widget(name, block), entry), args=(doc, *args), daemon=True)
        thread.start()
        return thread

    threads = [event("first", page, block=True)]
    assert entered["first"].wait(30)
    threads += [event("second", page), event("other page", other)]
    assert entered["other page"].wait(30)  # other sessions never wait for this one
    assert not entered["second"].wait(0.3)  # unserialized, it ran at once beside the first
    release.set()
    assert entered["second"].wait(30)
    for thread in threads:
        thread.join(30)


def test_a_change_queued_while_the_queue_is_taken_is_still_processed():
    """The loop queues a browser change on the widget and schedules the processing only if the queue was empty; a
    thread takes the queue. Taken between the loop's check and its addition, the change went to the fresh queue with
    nothing to process it, and the widget never moved again. The check is paused here at that point."""
    hardening.install()
    doc, widget = Document(), pn.widgets.FloatSlider()
    widget.get_root(doc)  # links the model's changes to the guarded method (bokeh checks its signature)
    checked, go = threading.Event(), threading.Event()
    processed: list[dict] = []
    widget._process_events = lambda events: processed.append(dict(events))

    class Queue(dict):
        def __bool__(self) -> bool:  # the loop's check: was a processing already scheduled?
            checked.set()
            assert go.wait(30)
            return super().__len__() > 0

    widget._events = Queue(value=1.0)  # a change whose processing is scheduled but has not taken the queue yet
    loop = threading.Thread(target=widget._server_change, args=(doc, "ref", None, "value_throttled", 0.0, 1.0))
    loop.start()
    assert checked.wait(30)
    taker = threading.Thread(target=widget._change_event, args=(doc,))
    taker.start()
    taker.join(0.3)  # unguarded, it took the queue at once, between the check and the addition
    go.set()
    loop.join(30)
    taker.join(30)
    assert processed == [{"value": 1.0, "value_throttled": 1.0}]  # the thread took both changes
    assert not widget._events  # and stranded none


def test_two_sessions_sliders_released_at_once_both_apply():
    """Two students release a slider at the same moment; Panel applies each change on a worker thread with the
    slider's read-only and constant flags lifted. Interleaved here by hand: the first thread has lifted them and
    restores them while the second is applying its change. On the class's shared parameter objects the second
    change failed ("Constant parameter 'value_throttled' cannot be modified")."""
    from panel import reactive

    def interleave(edit) -> None:
        first, second = pn.widgets.FloatSlider(), pn.widgets.FloatSlider()
        first_edit, second_edit = edit(first), edit(second)
        first_edit.__enter__()
        with second_edit:
            first_edit.__exit__(None, None, None)
            second.param.update(value=2.0, value_throttled=2.0)
        assert second.value_throttled == 2.0
        for slider in (first, second):  # and the flags are back where they were
            with pytest.raises(TypeError, match="Constant parameter"):
                slider.value_throttled = 3.0

    original = getattr(reactive.edit_readonly, "_isl_original", reactive.edit_readonly)  # Panel's own
    shared = pn.widgets.FloatSlider.param["value_throttled"]
    try:
        with pytest.raises(TypeError, match="Constant parameter 'value_throttled' cannot be modified"):
            interleave(original)  # Panel's own: the first restores the class's flag while the second is inside
        assert not shared.constant  # ... and the second's exit left it lifted for every slider made from now on
    finally:
        shared.constant = True
    hardening.install()
    assert reactive.edit_readonly is not original
    interleave(reactive.edit_readonly)


def test_panels_busy_counter_is_edited_by_one_thread_at_a_time():
    """Panel counts every browser event as "busy" on its process-wide ``state``, lifting the read-only flag of its
    ``busy`` parameter for the edit. Two worker threads interleaved there: the first restored the flag while the
    second was setting ``busy`` ("Read-only parameter 'busy' cannot be modified", a callback error on the page).
    By hand on one thread with Panel's own ``edit_readonly`` that fails; patched, a second thread's edit waits for
    the first and both events are counted and uncounted."""
    state_module = sys.modules["panel.io.state"]  # (the package exports its state object under that name)

    busy = pn.state.param["busy"]
    original = getattr(state_module.edit_readonly, "_isl_original", state_module.edit_readonly)
    first, second = original(pn.state), original(pn.state)
    first.__enter__()
    with pytest.raises(TypeError, match="Read-only parameter 'busy' cannot be modified"), second:
        first.__exit__(None, None, None)
        pn.state.busy = True
    busy.readonly = True  # what the second's exit lifted for good

    hardening.install()
    edit = state_module.edit_readonly
    assert edit is not original
    inside, release, counted = threading.Event(), threading.Event(), threading.Event()

    def hold() -> None:
        with edit(pn.state):
            inside.set()
            assert release.wait(30)

    def count() -> None:
        pn.state._add_busy_event("isl-test")
        pn.state._remove_busy_event("isl-test")
        counted.set()

    holder = threading.Thread(target=hold, daemon=True)
    holder.start()
    assert inside.wait(30)
    counter = threading.Thread(target=count, daemon=True)
    counter.start()
    assert not counted.wait(0.3)  # unserialized, it edited state at once, inside the first edit
    release.set()
    assert counted.wait(30)
    holder.join(30)
    counter.join(30)
    assert busy.readonly and not pn.state.busy and "isl-test" not in dict(pn.state._busy_counter)
