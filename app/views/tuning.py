"""Tuning curves: one family's statistic against its knob, per scenario preset, and the point the rule picks.

Every filter that does not know σ(t) has one knob — the ISL filters' ν, the learners' memory W (in sensor readings),
the robust filter's c, the IMM's switch probability and grid density — and :func:`isl_core.scenario.tuning.tune` sets
each by the same rule: the least, over the knob's grid, of the largest period statistic over the scenario table's
presets (the minimax). A curve here is a family's statistic — the largest over a preset's periods — against its knob,
one line per preset and a thick one for the largest over all of them, whose lowest point (marked) is the tuned knob. A
family with two knobs is drawn along its first (W for the robust filter, the switch probability for the IMM) at the
tuned value of the other. The tuning is the one cached for the page's α, m and w (computed on demand as the session's
long job).
"""

from __future__ import annotations

import html

import numpy as np
import panel as pn
import param
from bokeh.core.properties import value
from bokeh.models import ColumnDataSource, Legend, LegendItem, Span
from bokeh.plotting import figure
from panel.viewable import Viewer

from isl_core.scenario.heldout import held_out
from isl_core.scenario.presets import DEFAULT_RATE
from isl_core.scenario.table import knob_text, table_from
from isl_core.scenario.tuning import FAMILIES

from ..state import AppState
from ..text import R_MIN, powers
from .shipped import shipped_note
from .style import SIGMA_COLORS, TEXT_FONT, job_buttons, px, ratio_axis, styled, text_scale

__all__ = ["AXIS", "TuningView", "curves"]

#: per family: the knob drawn on the x axis, its label, and how a grid value maps to the axis (ν/β = 2^ℓ)
AXIS = {
    "isl": ("ell", "ν/β", lambda v: 2.0**v),
    "isl_model": ("ell", "ν/β", lambda v: 2.0**v),
    "kbf_adaptive": ("memory", "memory W (sensor readings)", float),
    "vb": ("memory", "memory W (readings)", float),
    "kbf_robust": ("memory", "memory W (readings), at the tuned c", float),
    "imm": ("switch", "switch probability a reading, at the tuned number of modes", float),
}
PRESET_COLORS = (*SIGMA_COLORS, "#666666")  #: one per preset (six)


def curves(tuning, family: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """(x, per preset the statistic (presets, points), the largest over the presets (points), the minimax point's
    index) along the family's drawn knob, the other knob (if any) at its tuned value."""
    knob, _, to_x = AXIS[family]
    best = tuning.minimax(family)
    others = {k: v for k, v in tuning.knobs[best].items() if k != knob}
    idx = [j for j in tuning.variants(family) if all(tuning.knobs[j].get(k) == v for k, v in others.items())]
    ratio = tuning.stats()[0]
    per_preset = np.array([[ratio[j, tuning.preset_cells(p)].max() for j in idx] for p in range(len(tuning.presets))])
    x = np.array([to_x(tuning.knobs[j][knob]) for j in idx])
    return x, per_preset, per_preset.max(axis=0), idx.index(best)


class TuningView(Viewer):
    """The curves of one family (a selector), the tuning's origin, and the long job that computes a tuning."""

    state = param.ClassSelector(class_=AppState)

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._family = pn.widgets.Select(
            label="family",
            options={label: f for f, (label, _) in FAMILIES.items()},
            value="vb",
            width=px(self.state, 260),
        )
        self._sources = [ColumnDataSource({"x": [], "y": []}, name=f"tuning-{p}") for p in range(len(PRESET_COLORS))]
        self._all = ColumnDataSource({"x": [], "y": []}, name="tuning-all")
        self._oracle = ColumnDataSource({"x": [], "y": [], "color": []}, name="tuning-oracle")
        self._mark = Span(location=1.0, dimension="height", line_color="#c00", line_width=2, visible=False)
        self._items: list[LegendItem] = []
        self._held: tuple | None = None  # (tuning, its cached held-out runs or None): read once per tuning
        self._figure = self._chart()
        self._note = pn.pane.Markdown("", margin=(0, 10), styles={"font-size": TEXT_FONT})
        self._family.param.watch(lambda event: self._update(), "value")
        self.state.scenarios.param.watch(lambda event: self._update(), ["tuning", "picture"])
        self._update()

    def _chart(self) -> figure:
        scale = text_scale(self.state)
        fig = styled(
            figure(
                x_axis_type="log",
                y_axis_type="log",
                height=360,
                sizing_mode="stretch_width",
                title="Tuning curve: the statistic against the knob (simulated)",
                tools="pan,wheel_zoom,box_zoom,reset,save",
            ),
            scale,
        )
        fig.yaxis.axis_label = "largest ratio over periods"  # per preset (the title and note say which)
        ratio_axis(fig, scale)
        fig.add_layout(Span(location=1.0, dimension="width", line_color="#888", line_width=1))
        fig.add_layout(self._mark)
        for p, src in enumerate(self._sources):
            line = fig.line("x", "y", source=src, color=PRESET_COLORS[p], line_width=2)
            self._items.append(LegendItem(label=value(""), renderers=[line], visible=False))
        every = fig.line("x", "y", source=self._all, color="#000", line_width=4, line_alpha=0.8)
        self._items.append(LegendItem(label=value("largest over the presets (the rule's)"), renderers=[every]))
        best = fig.scatter(
            "x",
            "y",
            source=self._oracle,
            size=11 * scale,
            marker="circle",
            fill_color="color",
            line_color="#000",
            line_width=1.5,
        )
        self._items.append(LegendItem(label=value("each preset's own best (oracle, a reference)"), renderers=[best]))
        fig.add_layout(
            Legend(
                items=self._items, location="top_left", label_text_font_size=f"{10 * scale:.3g}pt", click_policy="hide"
            ),
            "right",
        )
        return fig

    def _update(self) -> None:
        t, family = self.state.scenarios.tuning, self._family.value
        if t is None:
            shipped = getattr(self.state.scenarios.picture, "shipped", None)
            self._note.object = (
                shipped_note(shipped)
                if shipped is not None
                else (
                    "No tuning for this α, m and w yet: **Tune** computes it (a few minutes on two cores, then "
                    "kept) — until then the Scenario picture runs the filters at their constructors' "
                    "defaults, labelled *untuned*."
                )
            )
            for src in (*self._sources, self._all):
                src.data = {"x": [], "y": []}
            self._oracle.data = {"x": [], "y": [], "color": []}
            self._mark.visible = False
            return
        x, per_preset, largest, best = curves(t, family)
        for p, src in enumerate(self._sources):
            have = p < len(t.presets)
            src.data = {"x": x, "y": per_preset[p]} if have else {"x": [], "y": []}
            self._items[p].visible = have
            if have:
                self._items[p].label = value(t.preset_labels[p].replace("r_min", R_MIN))
        self._all.data = {"x": x, "y": largest}
        low = per_preset.argmin(axis=1)  # each preset's best along this curve: a reference no rule can pick blind
        self._oracle.data = {
            "x": x[low],
            "y": per_preset[np.arange(len(low)), low],
            "color": list(PRESET_COLORS[: len(low)]),
        }
        self._figure.xaxis.axis_label = AXIS[family][1]
        self._mark.update(location=float(x[best]), visible=True)
        knob, origin = powers(knob_text(t.knobs[t.minimax(family)])), t.origin.replace("r_min", R_MIN)
        oracle = "; ".join(
            f"{t.preset_labels[p].replace('r_min', R_MIN)}: {powers(knob_text(t.knobs[j]))}"
            for p, j in enumerate(t.oracle(family, p) for p in range(len(t.presets)))
        )
        self._note.object = (
            f"**{html.escape(FAMILIES[family][0])}**: tuned at {knob} (red line), where its largest "
            f"ratio over every preset and period is least: {largest[best]:.3g}. Oracle-tuned, each "
            f"preset at its own best knob (dots; a reference, since a filter that does not know σ "
            f"cannot know the preset either): {html.escape(oracle)}. Tuning: {origin}. {self._held_note(t, family)}"
        )

    def _held_note(self, t, family: str) -> str:
        """The family's tuned knob out of sample, when the held-out runs of this tuning are cached (``isl scenario``
        computes them): its worst cell on the report seeds against its tuning-seed figure, flagged if it left it."""
        if self._held is None or self._held[0] is not t:
            self._held = (t, held_out(t, compute=False))
        held = self._held[1]
        if held is None:
            return "Out of sample: not computed for this tuning yet (`isl scenario` computes it)."
        tab = table_from(t, held=held)
        r = next(i for i, row in enumerate(tab.rows) if row.name == family)
        verdict = (
            "**flagged**: it left the tuning seeds' interval" if tab.flagged[r] else "within the tuning seeds' interval"
        )
        return (
            f"Out of sample (seeds {held.seeds[0]}–{held.seeds[-1]}, never used to tune): its worst cell reads "
            f"{tab.held_figure[r]:.3g}, against {tab.tuned_figure[r]:.3g} [{tab.tuned_low[r]:.3g}, "
            f"{tab.tuned_high[r]:.3g}] on the tuning's seeds {t.seeds[0]}–{t.seeds[-1]} — {verdict}."
        )

    def __panel__(self):
        s = self.state
        p = s.scenarios.param
        run, cancel, progress = job_buttons(
            p.tune_busy,
            p.tune_progress,
            "Tune",
            s.scenarios.compute_tuning,
            s.scenarios.cancel_tuning,
            width=110,
            scale=text_scale(s),
        )
        intro = pn.pane.Markdown(
            "**One tuning rule for every filter.** Each family's knob is the one whose largest ratio over the "
            "scenario table's presets and periods is least (the minimax); the curves show the statistic against the "
            f"knob, preset by preset. Every filter reads the sensor {DEFAULT_RATE:g} times per 1/{R_MIN} at σ(0), "
            "each reading the integral of dY over its interval.",
            margin=(10, 10, 0, 10),
            styles={"font-size": TEXT_FONT},
        )
        return pn.Column(
            intro,
            pn.FlexBox(self._family, run, cancel, progress, flex_wrap="wrap", sizing_mode="stretch_width"),
            pn.pane.Markdown(p.tune_note, margin=(0, 10)),
            self._note,
            pn.pane.Bokeh(self._figure, margin=5, sizing_mode="stretch_width"),
            sizing_mode="stretch_width",
        )
