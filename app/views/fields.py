"""An input's refusal beside the input: a value that cannot be used is explained where it was typed.

:attr:`app.state.AppState.refusals` maps each refused input to its message until that input gets a good value.
:func:`field` puts under a widget the message of the input it edits, in a live region (``role="alert"``: a screen
reader reads it when it appears), so that a refusal made in the ν-sweep's tab, the scenario's inputs or the sidebar's
last box is read beside what caused it, not at the top of a sidebar scrolled out of view.
"""

from __future__ import annotations

import html

import panel as pn

__all__ = ["REFUSAL_CSS", "field", "refusal"]

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
