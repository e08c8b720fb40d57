"""A slider released again at the value it was last released at, after the server moved it, gets an answer.

A large run follows a slider on release only (``value_throttled``, app.views.controls). When the server moves the
slider (a refused run takes σ back, a preset), its copy of ``value`` moves and its ``value_throttled`` stays at the
last release, in the browser as on the server. Released at that value again, the browser changes ``value`` only, and
bokeh applies no change to ``value_throttled``: the change was acknowledged and nothing was done, no run, no refusal.

The browser's message is applied here as the server applies it (a ``PATCH-DOC`` to the session's document), so that
bokeh drops the unchanged property as it does when served; Panel then processes what changed."""

from __future__ import annotations

import math

import pytest
from bokeh.document import Document
from bokeh.document.events import ModelChangedEvent
from bokeh.protocol import Protocol

from app import pipeline
from app.state import AppState, session
from app.views import controls

BROWSER = object()  # the setter of the browser's changes (the server session, when served)


#: the page's widget for an input: σ's log-scale slider, m's whole-number slider (as the sidebar builds them)
WIDGETS = {
    "sigma": lambda state: controls.log_slider(state, "sigma"),
    "m": lambda state: controls._plain(state, "m", controls.IntSlider(start=1, end=6)),
}


@pytest.fixture
def page(monkeypatch):
    """A session whose every run is followed on release only, and whose σ ≥ 100 needs too many steps (so that a
    few-thousand-step run stands for the large ones: a default run is 1,458 steps, σ = 251 needs 2,950); ``bind(key)``
    gives the widget of input ``key`` in a document, and a function releasing it at a value."""
    monkeypatch.setattr(session, "LIVE_MAX_STEPS", 0)
    monkeypatch.setattr(pipeline, "APP_MAX_STEPS", 2_000)
    asked: list = []  # the request of every run the session asked for

    def compute(request, **kwargs):
        asked.append(request)
        return pipeline.compute(request, **kwargs)

    monkeypatch.setattr(session, "compute", compute)
    state = AppState()
    state.start()  # runs inline outside a server

    def bind(key: str):
        doc = Document()
        model = WIDGETS[key](state).get_root(doc)
        doc.add_root(model)

        def release(value: float) -> None:
            """The widget let go at ``value``: both properties sent, as the classroom's scripted students send them;
            bokeh applies the one that changed (a browser sends only that one)."""
            events = [ModelChangedEvent(doc, model, attr, value) for attr in ("value", "value_throttled")]
            Protocol().create("PATCH-DOC", events).apply_to_document(doc, BROWSER)

        return model, release

    return state, asked, bind


def test_a_release_at_a_refused_value_is_refused_again_each_time(page):
    state, asked, bind = page
    model, release = bind("sigma")
    assert not state.live and [r.sigma for r in asked] == [20.0]
    release(2.4)  # σ = 251: its run needs too many steps, σ goes back to 20
    assert [r.sigma for r in asked] == [20.0, 251.0] and "σ = 251" in state.message and state.sigma == 20.0
    assert math.isclose(model.value, math.log10(20.0)) and model.value_throttled == 2.4  # moved back, not released
    state.say("")  # the page's message read: the next answer must say it again
    release(2.4)
    assert [r.sigma for r in asked] == [20.0, 251.0, 251.0]  # unfixed: [20.0, 251.0], no run, no message
    assert "σ = 251" in state.message and state.sigma == 20.0


@pytest.mark.parametrize(
    ("key", "released", "value", "moved", "shown"),
    [("sigma", 1.5, 31.6, 10.0, 1.0), ("m", 2, 2, 3, 3)],
)
def test_a_release_at_the_last_released_value_after_the_server_moved_the_widget_runs(
    page, key, released, value, moved, shown
):
    state, asked, bind = page
    model, release = bind(key)
    release(released)
    state.set(key, moved)  # the server moves it (a preset, a link)
    assert model.value_throttled == released and model.value == shown
    release(released)
    # unfixed: no run of the released value again, the moved one's kept on screen
    assert [getattr(r, key) for r in asked][1:] == [value, moved, value] and state.get(key) == value
