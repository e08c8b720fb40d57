"""An input's refusal beside the input: a value that cannot be used is explained where it was typed.

:attr:`app.state.AppState.refusals` maps each refused input to its message until that input gets a good value.
:func:`field` puts under a widget the message of the input it edits, in a live region (``role="alert"``: a screen
reader reads it when it appears), so that a refusal made in the ν-sweep's tab, the scenario's inputs or the sidebar's
last box is read beside what caused it, not at the top of a sidebar scrolled out of view.
"""

from __future__ import annotations

import html
import math

import panel as pn

from ..inputs import TooLong

__all__ = ["REFUSAL_CSS", "field", "list_box", "parse_numbers", "refusal"]

REFUSAL_CSS = """
.isl-refusal { color: #8a1c1c; background: #fdecea; border-left: 4px solid #b42318; padding: 4px 8px;
               font-size: var(--isl-note-font, 13px); line-height: 1.35; }
"""


def refusal(state, name: str) -> pn.pane.HTML:
    """A pane showing why input ``name``'s last value was refused (hidden while there is nothing to say)."""
    pane = pn.pane.HTML(
        "", visible=False, stylesheets=[REFUSAL_CSS], margin=(0, 10, 6, 10), sizing_mode="stretch_width"
    )

    def show(*events) -> None:
        text = state.refusals.get(name, "")
        body = f"<div class='isl-refusal' role='alert'>{html.escape(text)}</div>" if text else ""
        if pane.object != body:
            pane.param.update(object=body, visible=bool(text))

    state.param.watch(show, ["refusals"])
    show()
    return pane


def field(state, name: str, widget, **column) -> pn.Column:
    """``widget`` (which edits input ``name``) with its refusal below it; as wide as the widget when it has a width
    (in a row of inputs that wraps, each keeps its own width)."""
    width = getattr(widget, "width", None)
    if "sizing_mode" not in column and isinstance(width, int):
        margin = widget.margin if isinstance(widget.margin, tuple) and len(widget.margin) == 4 else None
        column["width"] = width + (margin[1] + margin[3] if margin else 20)
    return pn.Column(widget, refusal(state, name), margin=0, **column)


def parse_numbers(text: str) -> list[float | str]:
    """``"2, 20, 200"`` → ``[2.0, 20.0, 200.0]``; an entry that is not a number stays text, which the state refuses
    by name (``"2, abc"``: "abc" is not a number), and one too long for a float is named so (:class:`TooLong`)."""

    def entry(v: str) -> float | str:
        try:
            x = float(v)
        except ValueError:
            return v.strip()
        spelled_inf = "inf" in v.lower()
        return TooLong(x) if math.isinf(x) and not spelled_inf else x

    return [entry(v) for v in text.replace(";", ",").split(",") if v.strip()]


def list_box(state, name: str, widget: pn.widgets.TextInput) -> pn.widgets.TextInput:
    """Two-way link of a text box of comma-separated numbers and the list input ``name``: what is typed is read by
    :func:`parse_numbers`; a refused list is shown beside the box, and the box shows the input's list again (on the
    session's next turn: Panel does not send back a change made while it applies the browser's)."""

    def text() -> str:
        return ", ".join(f"{v:g}" for v in state.get(name))

    def from_widget(event) -> None:
        values = parse_numbers(event.new)
        if values == state.get(name):
            return  # the input's own list (a revert's echo, or the same numbers spelled otherwise)
        state.set(name, values)
        if name in state.refusals:
            state.later(lambda: setattr(widget, "value", text()))

    widget.param.watch(from_widget, "value")
    state.watch(lambda *events: setattr(widget, "value", text()), [name])
    widget.value = text()
    return widget
