"""The dashboard's input widgets, and how a value the state refuses leaves them.

Panel's widgets, each with what the page needs of it: a value the browser sends that Panel cannot take is handed to
the state to refuse in words (:class:`Guarded`); the boxes read what is typed as a number (:class:`NumberInput`,
:class:`WholeInput`); the sliders skip Panel's debounce (:class:`Slider`, :class:`IntSlider`). When the state refuses
a value, :func:`revert` shows its own again; :func:`resend` repairs a value the browser and the server sent each other
at once. The bindings to the state are in :mod:`app.views.controls`.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from typing import Any, ClassVar

import panel as pn
import param

from .. import inputs

__all__ = ["Guarded", "IntSlider", "NumberInput", "Slider", "WholeInput", "resend", "revert", "same"]


class Guarded:
    """A widget whose impossible browser values become refusals in words.

    Panel converts and checks a value the browser sends before any watcher sees it: a scripted client's nan for an
    integer, 10³⁰⁸ on a log slider or 2.5 in the seed box raised there ("cannot convert float NaN to integer"), and the
    page showed "something went wrong" instead of the refusal the state gives every bad value, which names the input
    and its range. A value :meth:`fits` refuses goes to the binding's ``refuse`` (the state refuses it), not to Panel.
    """

    _refuse: Callable[[Any], None] | None = None  # where a value the widget cannot take goes (refuse_with)

    def refuse_with(self, refuse: Callable[[Any], None]) -> None:
        """Hand every value the browser sends that Panel cannot take to ``refuse`` (the binding to the state, which
        refuses it in words); without it, such a value goes to Panel as before."""
        self._refuse = refuse

    def fits(self, value) -> bool:
        """Whether Panel can take ``value`` for this widget."""
        return value is None or (
            isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)
        )

    def typed(self, value):
        """What the user meant by ``value``: a box's ±inf is a number typed too long for a float."""
        return value

    def _process_events(self, events: dict) -> None:
        refuse = self._refuse
        bad = [v for k, v in events.items() if k in ("value", "value_throttled") and not self.fits(v)]
        if bad and refuse is not None:
            events = {k: v for k, v in events.items() if k not in ("value", "value_throttled")}
            refuse(self.typed(bad[0]))
        if events:
            super()._process_events(events)  # type: ignore[misc]  # the Panel widget after this mixin has it


def _within(widget, value, integral: bool) -> bool:
    """A finite number inside ``widget``'s range (half a step of slack), whole if ``integral``."""
    if not (isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)):
        return False
    slack = 0.5 * float(widget.step or 0)
    return widget.start - slack <= value <= widget.end + slack and (not integral or float(value).is_integer())


class NumberInput(Guarded, pn.widgets.FloatInput):
    """A box for a number: anything else the browser sends is refused by the state, by name. BokehJS reads what is
    typed with ``Number()``: a number too long for a float (``1e400``, 5000 digits) arrives as ±inf, and is refused
    as what it is (:class:`app.inputs.TooLong`)."""

    def typed(self, value):
        return inputs.TooLong(value) if isinstance(value, float) and math.isinf(value) else value


class WholeInput(NumberInput):
    """A box for a whole number, stepping by 1. It reads what is typed as a number, like :class:`NumberInput`, and the
    state refuses a value that is not whole, by name: BokehJS's own whole-number box drops every character but digits
    as they are typed, so "1e400" became 1400 and "1.5" became 15 — and ran."""

    step = param.Number(default=1.0, doc="The arrow keys' step.")


class Slider(Guarded, pn.widgets.FloatSlider):
    """A FloatSlider whose changes reach the server at once, at the least server cost.

    Panel holds browser → server changes back a moment (``_debounce``) to merge bursts; :class:`app.jobs.Jobs`
    already keeps only the newest request, so the delay would only add latency to every update. Panel also
    counts each change as a "busy" event for a global busy indicator that this page does not show (the state's
    own ``busy`` drives the spinner); slider values are left out of that bookkeeping, which costs the server's loop
    time at every move (:ref:`performance-latency`).
    """

    _debounce = 0
    _busy__ignore: ClassVar[list[str]] = ["value", "value_throttled"]

    def fits(self, value) -> bool:
        return _within(self, value, integral=False)


class IntSlider(Guarded, pn.widgets.IntSlider):
    """An IntSlider without Panel's debounce and busy bookkeeping (see :class:`Slider`)."""

    _debounce = 0
    _busy__ignore: ClassVar[list[str]] = ["value", "value_throttled"]

    def fits(self, value) -> bool:
        return _within(self, value, integral=True)


def resend(widget) -> None:
    """Send ``widget``'s value to the browser again. A preset moves a slider from the server while a key moves it in
    the browser: each side's message crosses the other's, and the browser ends on the preset's value while the server
    (and the link, and the run) took the key's. Bokeh sends a property only when its server copy (the model's) changes.

    Bokeh writes a browser's value into that copy when the message arrives; Panel hands it to the widget later, on its
    thread pool. So the copy holds either the browser's newest value — the one the widget took, or a newer one Panel
    has still queued (a key pressed again) — and it is sent as a change to itself; or the preset's, written over the
    browser's value in between, while the widget took the browser's value (the run's): the copy then takes the
    widget's value, and that change is sent. Runs on the session's loop with its lock held: the loop alone queues the
    browser's values, and Panel takes them only under that lock. Any widget whose value is one property of its model
    (a checkbox's model holds it as ``active``)."""
    ((prop, value),) = widget._process_param_change({"value": widget.value}).items()
    for model, _ in list(widget._models.values()):
        held = getattr(model, prop)
        if prop in widget._events or held == value:
            model.trigger(prop, held, held)
        else:
            setattr(model, prop, value)


def revert(state, widget, shown: Callable[[], Any]) -> None:
    """Show the input's value again in ``widget`` once the state has refused what the browser sent: ``shown()`` is
    that value as the widget holds it (None: it holds it already). Done on the session's next turn — a change made
    while Panel applies the browser's own is not sent back to it — and sent even when the server's copy of the widget
    never took the refused value (the browser shows it all the same). The binding must not hand the state its own
    value back (:func:`same`): that would lift the refusal it has just made."""

    def back() -> None:
        value = shown()
        if value is not None and value != widget.value:
            widget.value = value  # the binding's echo: the state already holds it
        else:
            widget.param.trigger("value")

    state.later(back)


def same(a, b) -> bool:
    """Whether a widget's value is the state's own (the echo of a revert, not a new value)."""
    try:
        return bool(a == b)
    except Exception:  # noqa: BLE001  (a value's own __eq__ may raise, e.g. numpy's ambiguous truth: not the same)
        return False
