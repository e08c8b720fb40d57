"""Validation once: a slider's request is checked at the boundary (:func:`app.inputs.clean`) and by the core's
constructors, not again by every function the run goes through."""

from __future__ import annotations

import collections
import math
import sys

import pytest

from app.state import AppState
from app.views.controls import log_slider

pytestmark = pytest.mark.app


def _checks_during(action) -> collections.Counter:
    """How often each argument name reached a check of :mod:`isl_core.validate`, how often the boundary cleaned a
    value, and how many models were made, while ``action()`` ran (a profile hook sees every Python call)."""
    seen: collections.Counter = collections.Counter()

    def hook(frame, event, arg):
        if event != "call":
            return
        code = frame.f_code
        if code.co_filename.endswith("isl_core/validate.py") and code.co_name in ("check_real", "check_int"):
            seen[frame.f_locals.get("name")] += 1
        elif code.co_filename.endswith("app/inputs.py") and code.co_name == "clean":
            seen["boundary"] += 1
        elif code.co_filename.endswith("isl_core/model.py") and code.co_name == "__post_init__":
            seen["models"] += 1

    sys.setprofile(hook)
    try:
        action()
    finally:
        sys.setprofile(None)
    return seen


def test_one_slider_request_checks_sigma_once_per_model_it_makes():
    state = AppState()
    state.start()
    slider = log_slider(state, "sigma")
    seen = _checks_during(lambda: setattr(slider, "value", math.log10(55.0)))
    assert state.run.model.sigma == 55.0  # the request ran
    assert seen["boundary"] == 1
    # the run's model and the fixed-gain filters' design models: each checks its σ when made, nothing after it
    assert seen["models"] >= 1 and seen["sigma"] == seen["models"], dict(seen)


@pytest.mark.parametrize("name", ["alpha", "beta", "w", "sigma", "nu", "m", "seed", "horizon"])
def test_each_input_takes_its_range_from_the_cores_table(name):
    """The session's inputs are declared with the table's ranges, and the boundary refuses just outside them with
    the range in words (one table: a page, a link and the core never disagree on a bound)."""
    from isl_core import BOUNDS

    state = AppState()
    bound = BOUNDS[name]
    assert state.param[name].bounds == bound.range and state.param[name].label.startswith(bound.symbol)
    lo, hi = bound.range
    beyond = hi + 1 if bound.kind == "int" else hi * 1.5
    setattr(state, name, beyond)
    assert getattr(state, name) != beyond and name in state.refusals

    def plain(x: float) -> str:  # as people write a bound: whole numbers in full
        return str(int(x)) if float(x).is_integer() else f"{x:g}"

    assert f"from {plain(lo)} to {plain(hi)};" in state.refusals[name], state.refusals[name]
