"""A slider's value sent to the browser again after the server moved it (app.views.controls): at the release, never
in the middle of a drag, where it moved the handle back to where the browser had been a round trip earlier."""

from __future__ import annotations

import param
import pytest

from app.state import AppState
from app.views import controls


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
