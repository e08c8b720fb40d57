"""The number boxes, headless: what a box reads, how a refusal is named, and that a refused value leaves the box.

Panel's ``_process_events`` is what a browser's change goes through; outside a server the state's ``later`` runs at
once, so the box's value after the call is what the page would be sent back.
"""

import math

import pytest

from app import inputs
from app.state import AppState
from app.views.controls import ControlsView, WholeInput
from app.views.fields import list_box, parse_numbers


@pytest.fixture
def state():
    s = AppState()
    s.start()
    return s


@pytest.mark.parametrize("typed", [-5.0, 1.5, 3e9, math.inf, None])
def test_a_refused_seed_leaves_the_box_which_shows_the_seed_again(state, typed):
    box = ControlsView(state=state)._seed
    run = state.run
    box._process_events({"value": typed})
    assert state.seed == 1 and state.run is run and "seed" in state.refusals
    assert box.value == 1  # back to the run's seed (a served page is sent it on the session's next turn)


def test_the_seed_box_is_a_whole_number_box_stepping_by_one(state):
    box = ControlsView(state=state)._seed
    assert isinstance(box, WholeInput) and box.step == 1 and box.mode == "float"  # reads "1e400" as a number
    box._process_events({"value": 2.0})  # the arrow key's step
    assert state.seed == 2 and state.refusals == {}


def test_a_number_too_long_for_a_float_is_named_as_such_not_as_inf(state):
    box = ControlsView(state=state)._seed
    box._process_events({"value": math.inf})  # what BokehJS reads from "1e400" or 5000 digits
    text = state.refusals["seed"]
    assert "too long for a float" in text and "inf" not in text.replace("infinity", "")
    state.set("seed", math.inf)  # a script's inf is what it is
    assert "inf is not a finite number" in state.refusals["seed"]


def test_a_list_box_reads_numbers_names_the_too_long_and_shows_the_list_again(state):
    import panel as pn

    assert parse_numbers("2, 1e400; abc") == [2.0, inputs.TooLong("inf"), "abc"]
    assert math.isinf(parse_numbers("inf")[0]) and not isinstance(parse_numbers("inf")[0], inputs.TooLong)
    box = list_box(state, "sweep_sigmas", pn.widgets.TextInput())
    before = box.value
    box.value = "2, 1e400"
    assert "too long for a float" in state.refusals["sweep_sigmas"] and box.value == before
    box.value = "3, 30"
    assert state.sweep.sigmas == [3.0, 30.0] and state.refusals == {} and box.value == "3, 30"
