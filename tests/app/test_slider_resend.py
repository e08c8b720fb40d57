"""A slider's value sent to the browser again after the server moved it (app.views.controls): at the release, never
in the middle of a drag, where it moved the handle back to where the browser had been a round trip earlier."""

from __future__ import annotations

import panel as pn
import param
import pytest
from bokeh.document import Document
from bokeh.document.events import ModelChangedEvent

from app.state import AppState
from app.views import controls, widgets


@pytest.fixture
def sent(monkeypatch) -> list:
    resent: list = []
    monkeypatch.setattr(controls, "resend", resent.append)
    return resent


def test_a_value_moved_by_the_server_is_sent_again_at_the_release_not_mid_drag(sent):
    state = AppState()
    state.start()
    slider = controls.log_slider(state, "sigma")
    state.sigma = 200.0  # the server moves the slider (a preset, a link)
    for step in (2.0, 2.05, 2.1):  # the browser drags: values only
        slider.value = step
    assert sent == [] and state.sigma == 126.0  # followed live, nothing sent back while dragging
    with param.edit_constant(slider):
        slider.value_throttled = 2.1  # let go
    assert sent == [slider]
    slider.value = 2.2  # a later drag, no server move since: nothing to send
    assert sent == [slider]


def in_a_document(widget) -> tuple:
    """``widget``'s model in a document of its own, and the list of (property, value) changes the document sends."""
    doc = Document()
    doc.add_root(widget.get_root(doc))
    (model, _), *_ = widget._models.values()
    sent: list = []
    doc.on_change(lambda event: sent.append((event.attr, event.new)) if isinstance(event, ModelChangedEvent) else None)
    return model, sent


def test_a_resend_sends_the_widget_s_value_even_where_a_preset_wrote_over_its_model_copy():
    """Bokeh writes the browser's value into the widget's model copy when it arrives, and Panel hands it to the widget
    later: a preset applied in between leaves its own value in the copy, and sending the copy again would show the
    preset beside a run made from the browser's value. Sent is the widget's value: the run's."""
    slider = widgets.Slider(label="σ", start=0.0, end=3.0, step=0.01, value=1.3)
    model, sent = in_a_document(slider)

    widgets.resend(slider)  # the copy holds the widget's value: sent as a change to itself
    assert sent == [("value", 1.3)]

    slider.value = 2.3  # the preset, written into the copy
    with param.discard_events(slider):  # the browser's value, handed to the widget after the preset: not to the copy
        slider.value = 1.31
    sent.clear()
    widgets.resend(slider)
    assert model.value == 1.31 and sent == [("value", 1.31)]


def test_a_resend_keeps_a_newer_browser_value_panel_has_still_queued():
    """A key pressed again: its value is in the copy and in Panel's queue, not yet in the widget. The copy is the
    browser's newest value and is sent as it is; the widget's older one would move the slider back."""
    slider = widgets.Slider(label="σ", start=0.0, end=3.0, step=0.01, value=1.31)
    model, sent = in_a_document(slider)
    slider._changing[model.ref["id"]] = ["value"]  # the browser's value reaches the copy (Panel's echo guard) ...
    model.value = 1.32
    slider._events = {"value": 1.32}  # ... and waits in Panel's queue
    sent.clear()
    widgets.resend(slider)
    assert model.value == 1.32 and sent == [("value", 1.32)]


def test_a_checkbox_is_sent_again_as_its_model_holds_it():
    """β from w is a checkbox bound like the sliders: its model holds the value as ``active``."""
    box = pn.widgets.Checkbox(value=True, label="β from w")
    model, sent = in_a_document(box)
    widgets.resend(box)
    assert sent == [("active", True)]
    with param.discard_events(box):
        box.value = False
    sent.clear()
    widgets.resend(box)
    assert model.active is False and sent == [("active", False)]
