"""Extra-filters panel: checkboxes for the baselines drawn on the run, σ̄ and the plausible σ range.

The checked filters (:mod:`app.extras`) ride on the displayed run (same noise) and appear in the trajectories
(one colour each), in the numbers table and as theory curves in the ν sweep. σ̄ is the design σ of the
mismatched Kalman–Bucy filter; [σ min, σ max] is the range the minimax and adaptive filters and the
worst-case tab assume.
"""

from __future__ import annotations

import panel as pn
import param
from panel.viewable import Viewer

from isl_core.filters.baselines import LABELS

from ..extras import EXTRA_NAMES
from ..state import AppState, declaration
from .fields import field
from .style import EXTRA_COLORS, NOTE_FONT
from .widgets import Guarded, NumberInput, WholeInput, revert, same

__all__ = ["FiltersPanel", "bind", "number"]


def bind(state: AppState, name: str, widget):
    """Two-way link of ``widget.value`` and input ``name``; the state refuses bad values (with a message)."""
    quiet = [False]

    def from_widget(event) -> None:
        value = list(event.new) if isinstance(event.new, (list, tuple)) else event.new
        if quiet[0] or (value is not None and same(value, state.get(name))):  # the state's own value (a revert's echo)
            return
        state.set(name, value)
        if name in state.refusals:  # refused: the box shows the state's value again
            revert(state, widget, lambda: state.get(name))

    def from_state(*events) -> None:
        value = state.get(name)
        if value != widget.value:
            quiet[0] = True
            try:
                widget.value = value
            finally:
                quiet[0] = False

    def refuse(raw) -> None:
        state.set(name, raw)
        revert(state, widget, lambda: state.get(name))

    widget.param.watch(from_widget, "value")
    if isinstance(widget, Guarded):  # a value the widget cannot take: the state refuses it, in words
        widget.refuse_with(refuse)
    state.watch(from_state, [name])
    from_state()
    return widget


def number(state: AppState, name: str, **widget):
    """A number box for input ``name``, with its label and doc. The state checks what is typed and says why a value is
    refused; the box itself has no range (BokehJS's box drops a value outside its range without a word, and the
    page kept showing it while the run stayed as it was)."""
    p = declaration(name)
    kind = WholeInput if isinstance(p, param.Integer) else NumberInput
    return bind(state, name, kind(label=p.label, description=p.doc, **widget))


def _swatch_css(name: str) -> str:
    """A square of the filter's plot colour before its checkbox's label."""
    return (
        f".bk-label::before {{ content: '\\25A0'; color: {EXTRA_COLORS[name]}; font-size: 18px; "
        "margin-right: 6px; vertical-align: -2px; }"
    )


class FiltersPanel(Viewer):
    """Checkboxes of the extra filters (with their plot colour), σ̄ and the σ range."""

    state = param.ClassSelector(class_=AppState)

    def __init__(self, **params) -> None:
        super().__init__(**params)
        s = self.state
        self._boxes = {}
        for name in EXTRA_NAMES:  # the label names the box for a screen reader; its colour swatch is drawn by CSS
            box = pn.widgets.Checkbox(
                value=name in s.baselines.extra_filters,
                label=LABELS[name],
                margin=(6, 10),
                css_classes=[f"extra-{name}"],
                sizing_mode="stretch_width",
                stylesheets=[_swatch_css(name)],
            )
            box.param.watch(self._on_box, "value")
            self._boxes[name] = box
        s.baselines.param.watch(self._from_state, ["extra_filters"])
        self._design = number(s, "sigma_design", width=170, step=1.0)
        self._lo = number(s, "sigma_min", width=110, step=1.0)
        self._hi = number(s, "sigma_max", width=110, step=10.0)

    def _on_box(self, *events) -> None:
        chosen = [n for n, box in self._boxes.items() if box.value]
        if chosen != list(self.state.baselines.extra_filters):
            self.state.baselines.extra_filters = chosen

    def _from_state(self, *events) -> None:
        for name, box in self._boxes.items():
            want = name in self.state.baselines.extra_filters
            if box.value != want:
                box.value = want

    def __panel__(self):
        rows = [self._boxes[n] for n in EXTRA_NAMES]
        help_text = pn.pane.Markdown(
            "Drawn on the same run (same noise). The model-aware ISL filter uses the ν above; the Kalman–Bucy "
            "filter 'for max σ' and the adaptive one assume σ ∈ [σ min, σ max].",
            styles={"font-size": NOTE_FONT},
            margin=(0, 10),
        )
        s = self.state
        return pn.Card(
            *rows,
            field(s, "sigma_design", self._design),
            pn.Row(field(s, "sigma_min", self._lo), field(s, "sigma_max", self._hi)),
            help_text,
            title="Other filters (σ unknown)",
            collapsed=False,
            sizing_mode="stretch_width",
        )
