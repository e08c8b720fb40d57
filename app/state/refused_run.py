"""A run the dashboard cannot show, refused at the inputs that asked for it.

Some values are refused only in combination: α = 100 is in range, and so is σ = 741, but together with the horizon
they need more steps than the dashboard allows (:data:`app.pipeline.APP_MAX_STEPS`); a filter may diverge at a
setting each of whose inputs is fine. Such a refusal comes back from the run's job, after the control has moved. The
controls then return to the inputs of the run on screen — so that every control, the link and the picture describe
the same run — and the refusal is shown beside each input that moved since that run (the one just moved, for a
slider or a box), naming it, its refused value and the value it is back at.
"""

from __future__ import annotations

from ..jobs import Cancelled
from ..pipeline import describe
from .baselines import BaselinesRoom
from .session_inputs import INPUTS

__all__ = ["RUN_KEYS", "moved", "refusal_text", "refuse_run", "run_refusal_shown"]

RUN_KEYS = (*INPUTS, *BaselinesRoom.KEYS)  #: the inputs a displayed run is made of (the model's and the extras')


def moved(asked: dict, shown: dict) -> list[str]:
    """The inputs whose values in ``asked`` (a refused run's) differ from ``shown`` (the run on screen's)."""
    return [key for key in RUN_KEYS if asked[key] != shown[key]]


def _value(value) -> str:
    if isinstance(value, bool):
        return "on" if value else "off"
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(str(v) for v in value) + "]"
    return str(value)


def refusal_text(labels: dict[str, str], keys: list[str], asked: dict, shown: dict, reason: str) -> str:
    """The refusal of the inputs ``keys`` (labelled by ``labels``) at their ``asked`` values, for ``reason``, each
    back at its ``shown`` value."""
    refused = ", ".join(f"{labels[k]} = {_value(asked[k])}" for k in keys)
    back = ", ".join(f"{labels[k]} is back at {_value(shown[k])}" for k in keys)
    return f"Refused: {refused} — with the other inputs, {reason}. {back}, the run on screen."


def _label(state, key: str) -> str:
    obj, name = state.owner(key)
    return obj.param[name].label


def refuse_run(state, asked: dict, error: BaseException) -> None:
    """``state``'s run for the inputs ``asked`` failed with ``error``: the inputs that moved since the run on screen go
    back to its values, and the refusal stands beside each of them and in the page's message (the module docstring).
    With no run on screen (or a cancelled job) there is nothing to go back to: the message alone says why."""
    shown = state.shown_inputs
    keys = moved(asked, shown) if shown is not None and not isinstance(error, Cancelled) else []
    if not keys:
        kept = "The last good run is kept." if state.run is not None else "Nothing is shown until it is changed."
        state.say(f"{describe(error)}. {kept}", "danger")
        return
    state.restore({k: shown[k] for k in keys})
    text = refusal_text({k: _label(state, k) for k in keys}, keys, asked, shown, describe(error))
    state.say(text, "danger")
    state.refusals = dict.fromkeys(keys, text)


def run_refusal_shown(state) -> bool:
    """Whether the refusals on screen are a refused run's (:func:`refuse_run`: one text, beside the inputs and in the
    page's message). A later run replaces the run they say the inputs are back at, so they end with it."""
    return bool(state.refusals) and not state.message_inline and set(state.refusals.values()) == {state.message}
