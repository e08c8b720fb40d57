"""Extra-filters panel: checkboxes for the baselines drawn on the run, σ̄ and the plausible σ range.

The checked filters (:mod:`app.extras`) ride on the displayed run (same noise) and appear in the trajectories
(one colour each), in the numbers table and as theory curves in the ν sweep. σ̄ is the design σ of the
mismatched Kalman–Bucy filter; [σ min, σ max] is the range the minimax and adaptive filters and the
worst-case tab assume.
"""
from __future__ import annotations

import html

import panel as pn
import param
from panel.viewable import Viewer

from isl_core.baselines import LABELS

from ..extras import EXTRA_NAMES
from ..state import AppState
from .style import EXTRA_COLORS

__all__ = ["FiltersPanel", "bind"]


def bind(state: AppState, name: str, widget):
    """Two-way link of ``widget.value`` and input ``name``; the state refuses bad values (with a message)."""
    quiet = [False]

    def from_widget(event) -> None:
        if not quiet[0]:
            setattr(state, name, list(event.new) if isinstance(event.new, (list, tuple)) else event.new)

    def from_state(*events) -> None:
        value = getattr(state, name)
        if value != widget.value:
            quiet[0] = True
            try:
                widget.value = value
            finally:
                quiet[0] = False

    widget.param.watch(from_widget, "value")
    state.param.watch(from_state, [name])
    from_state()
    return widget


def _swatch(name: str) -> str:
    return (f"<span style='color:{EXTRA_COLORS[name]};font-size:18px'>&#9632;</span> "
            f"{html.escape(LABELS[name])}")


class FiltersPanel(Viewer):
    """Checkboxes of the extra filters (with their plot colour), σ̄ and the σ range."""

    state = param.ClassSelector(class_=AppState)

    def __init__(self, **params) -> None:
        super().__init__(**params)
        s = self.state
        self._boxes = {}
        for name in EXTRA_NAMES:
            box = pn.widgets.Checkbox(value=name in s.extra_filters, margin=(8, 0, 0, 10), width=20,
                                      css_classes=[f"extra-{name}"])
            box.param.watch(self._on_box, "value")
            self._boxes[name] = box
        s.param.watch(self._from_state, ["extra_filters"])
        p = s.param
        self._design = bind(s, "sigma_design", pn.widgets.FloatInput(
            label=p.sigma_design.label, start=0.1, end=1000.0, step=1.0, width=170))
        self._lo = bind(s, "sigma_min", pn.widgets.FloatInput(label=p.sigma_min.label, start=0.1, end=1000.0,
                                                               step=1.0, width=110))
        self._hi = bind(s, "sigma_max", pn.widgets.FloatInput(label=p.sigma_max.label, start=0.1, end=1000.0,
                                                               step=10.0, width=110))

    def _on_box(self, *events) -> None:
        chosen = [n for n, box in self._boxes.items() if box.value]
        if chosen != list(self.state.extra_filters):
            self.state.extra_filters = chosen

    def _from_state(self, *events) -> None:
        for name, box in self._boxes.items():
            want = name in self.state.extra_filters
            if box.value != want:
                box.value = want

    def __panel__(self):
        rows = [pn.Row(self._boxes[n], pn.pane.HTML(_swatch(n), margin=(6, 0, 0, 0)), height=32)
                for n in EXTRA_NAMES]
        help_text = pn.pane.Markdown(
            "Drawn on the same run (same noise). The model-aware ISL filter uses the ν above; the Kalman–Bucy "
            "filter 'for max σ' and the adaptive one assume σ ∈ [σ min, σ max].",
            styles={"font-size": "12px"}, margin=(0, 10))
        return pn.Card(*rows, pn.Row(self._design), pn.Row(self._lo, self._hi), help_text,
                       title="Other filters (σ unknown)", collapsed=False, sizing_mode="stretch_width")
