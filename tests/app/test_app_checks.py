"""Validation in two places: a slider's request is judged by the input's declaration when it is assigned (the
boundary) and by the core's constructors, not again by every function the run goes through."""

from __future__ import annotations

import collections
import math
import sys

import pytest

from app.state import AppState
from app.views.controls import ALPHA_SLIDER_LOW, log_slider

pytestmark = pytest.mark.app

#: where the core's checks live, and the module of param's declarations (what judges an assignment)
_VALIDATE, _PARAM = "isl_core/validate.py", "param/parameters.py"


def _checks_during(action) -> tuple[collections.Counter, dict[str, set[str]]]:
    """How often each argument name reached a check of :mod:`isl_core.validate` or a declaration's ``_validate``
    (param's), and from which functions (the places that check it), while ``action()`` ran (a profile hook sees every
    Python call)."""
    calls: collections.Counter = collections.Counter()
    places: dict[str, set[str]] = collections.defaultdict(set)

    def hook(frame, event, arg):
        if event != "call":
            return
        code = frame.f_code
        if code.co_filename.endswith(_VALIDATE) and code.co_name.startswith("check_"):
            name = frame.f_locals.get("name")
            caller = frame.f_back
            while caller is not None and caller.f_code.co_filename.endswith((_VALIDATE, "isl_core/bounds.py")):
                caller = caller.f_back  # a Bound's real()/whole() is the table's door to the same check
            assert caller is not None
            calls[name] += 1
            places[name].add(f"{caller.f_code.co_filename.rsplit('/', 1)[-1]}:{caller.f_code.co_name}")
        elif code.co_filename.endswith(_PARAM) and code.co_name == "_validate":
            name = frame.f_locals["self"].name
            calls[name] += 1
            places[name].add("declaration")

    sys.setprofile(hook)
    try:
        action()
    finally:
        sys.setprofile(None)
    return calls, places


@pytest.mark.parametrize(("name", "value"), [("sigma", 55.0), ("alpha", 2.0), ("nu", 5.0), ("horizon", 20.0)])
def test_one_slider_request_checks_each_input_in_at_most_two_places(name, value):
    """The moved input is judged once by its declaration, and every input of the run at most by one constructor of
    the core besides (a Model checks α, β, σ and m; the ISL filter ν; the run's plan its horizon; the simulation its
    seed) — however many models and filters the run makes, none is checked again by the functions it goes through."""
    state = AppState()
    state.start()
    slider = log_slider(state, name, lo=ALPHA_SLIDER_LOW if name == "alpha" else None)
    calls, places = _checks_during(lambda: setattr(slider, "value", math.log10(value)))
    ran = state.run.model if name in ("sigma", "alpha") else state.run if name == "nu" else state
    assert getattr(ran, name) == value  # the request ran
    assert places[name] >= {"declaration"} and calls[name] >= 2, (calls, places)  # the boundary, then the core
    for each in ("alpha", "beta", "w", "sigma", "nu", "m", "seed", "horizon"):
        assert len(places[each]) + (each != name) <= 2, (each, places[each])
    assert places["sigma"] - {"declaration"} == places["m"] == {"model.py:__post_init__"}, places
    assert places["nu"] - {"declaration"} == {"isl.py:isl_filter"}, places["nu"]


@pytest.mark.parametrize("name", ["alpha", "beta", "w", "sigma", "nu", "m", "seed", "horizon"])
def test_each_input_takes_its_range_from_the_cores_table(name):
    """The session's inputs are declared with the table's ranges; param refuses just outside them, and the boundary
    says so with the range in words (one table: a page, a link and the core never disagree on a bound)."""
    from isl_core import BOUNDS

    state = AppState()
    bound = BOUNDS[name]
    assert state.param[name].bounds == bound.range and state.param[name].label.startswith(bound.symbol)
    lo, hi = bound.range
    beyond = hi + 1 if bound.kind == "int" else hi * 1.5
    with pytest.raises(ValueError, match=f"parameter 'AppState.{name}'"):
        setattr(state, name, beyond)
    state.set(name, beyond)
    assert getattr(state, name) != beyond and name in state.refusals

    def plain(x: float) -> str:  # as people write a bound: whole numbers in full
        return str(int(x)) if float(x).is_integer() else f"{x:g}"

    assert f"from {plain(lo)} to {plain(hi)};" in state.refusals[name], state.refusals[name]
