"""ν-sweep view (paper A, Fig. 2): the ISL filter's RMSE ratio š_i/s_i against ν/β for a few σ.

One log–log plot per coordinate i (columns of Fig. 2) for the current α, β and m: theory curves (statistical
linearization, B.48, :ref:`linearization`) drawn at once, one line style per σ (Fig. 2: σ = 2 dotted, 20 dashed, 200
solid); simulated points with 95 % intervals on demand; the current ν as a vertical line; ratio 1 (the
optimum) as a horizontal one. Extra filters (:mod:`app.extras`) with a theory add their curves in their own
colour, with the σ line styles: the model-aware ISL filter over ν, the fixed-gain Kalman–Bucy filters flat.
Plots are built once and updated in place.
"""

from __future__ import annotations

import numpy as np
import panel as pn
import param
from bokeh.core.properties import value
from bokeh.models import ColumnDataSource, Legend, LegendItem, Span, Whisker
from bokeh.plotting import figure
from panel.viewable import Viewer

from isl_core import M_MAX
from isl_core.filters.baselines import LABELS

from ..pipeline import COORDINATES
from ..state import AppState
from .controls import log_slider
from .fields import field, list_box
from .style import (
    EXTRA_COLORS,
    NOTE_FONT,
    SIGMA_COLORS,
    SIGMA_DASHES,
    SUBSCRIPT,
    TEXT_FONT,
    job_buttons,
    px,
    ratio_axis,
    styled,
    text_scale,
)

__all__ = ["SweepView"]

_SLOTS = len(SIGMA_COLORS)
_EXTRA_CURVES = ("kbf_mismatched", "kbf_minimax", "isl_model")  #: extra filters with a theory (app.sweeps)


def _positive(a: np.ndarray) -> np.ndarray:
    """Finite positive values kept, the rest NaN (gaps on a log axis)."""
    a = np.asarray(a, dtype=float)
    return np.where(np.isfinite(a) & (a > 0), a, np.nan)


class SweepView(Viewer):
    """Theory curves, simulated points with intervals, the current ν, and the sweep's controls."""

    state = param.ClassSelector(class_=AppState)

    def __init__(self, **params) -> None:
        super().__init__(**params)
        # per coordinate's plot: per σ slot, the theory curve's and the simulated points' sources, legend entries
        self._lines: list[list[ColumnDataSource]] = []
        self._points: list[list[ColumnDataSource]] = []
        self._renderers: list[list[LegendItem]] = []
        self._nu_marks: list[Span] = []  # the current ν
        self._extra_lines: list[dict[str, list[ColumnDataSource]]] = []
        self._extra_legend = pn.pane.HTML("", margin=(0, 10), styles={"font-size": NOTE_FONT})
        self._figures = [self._figure(i) for i in range(M_MAX)]
        self._panes = [pn.pane.Bokeh(f, margin=5, sizing_mode="stretch_width") for f in self._figures]
        self._rows = (pn.Row(sizing_mode="stretch_width"), pn.Row(sizing_mode="stretch_width"))
        s = self.state
        s.sweep.want_curves()
        s.sweep.param.watch(self._update_curves, ["curves"])
        s.sweep.param.watch(self._update_points, ["points"])
        s.param.watch(self._update_nu, ["nu", "alpha", "beta_from_w", "w", "beta"])
        s.param.watch(self._update_layout, ["m"])
        self._update_layout()
        self._update_curves()
        self._update_points()
        self._update_nu()

    def _figure(self, i: int) -> figure:
        k = str(i + 1).translate(SUBSCRIPT)
        scale = text_scale(self.state)
        fig = styled(
            figure(
                x_axis_type="log",
                y_axis_type="log",
                height=400,
                sizing_mode="stretch_width",
                title=f"X{k} — {COORDINATES[i]}",
                tools="pan,wheel_zoom,box_zoom,reset,save",
            ),
            scale,
        )
        fig.xaxis.axis_label = "ν/β"
        fig.yaxis.axis_label = f"š{k}/s{k}  (ISL RMSE / optimal)"
        ratio_axis(fig, scale)
        fig.add_layout(Span(location=1.0, dimension="width", line_color="#888", line_width=1))
        mark = Span(location=1.0, dimension="height", line_color="#c00", line_width=2, line_alpha=0.7)
        fig.add_layout(mark)
        lines, points, items = [], [], []
        for j in range(_SLOTS):
            line_src = ColumnDataSource({"x": [], "y": []}, name=f"sweep-theory-{i + 1}-{j}")
            pt_src = ColumnDataSource({"x": [], "y": [], "lower": [], "upper": []}, name=f"sweep-sim-{i + 1}-{j}")
            line = fig.line(
                "x", "y", source=line_src, line_color=SIGMA_COLORS[j], line_dash=SIGMA_DASHES[j], line_width=2.2
            )
            dots = fig.scatter("x", "y", source=pt_src, size=8, color=SIGMA_COLORS[j], marker="circle")
            fig.add_layout(
                Whisker(
                    source=pt_src,
                    base="x",
                    lower="lower",
                    upper="upper",
                    dimension="height",
                    line_color=SIGMA_COLORS[j],
                    line_width=1.5,
                )
            )
            items.append(LegendItem(label=value(""), renderers=[line, dots], visible=False))
            lines.append(line_src)
            points.append(pt_src)
        legend = Legend(
            items=items, orientation="horizontal", label_text_font_size=f"{11 * scale:.3g}pt", padding=2, margin=2
        )
        fig.add_layout(legend, "above")
        extra_lines = {}  # their legend is one HTML line above the plots (three legends per plot do not fit)
        for name in _EXTRA_CURVES:
            srcs = [ColumnDataSource({"x": [], "y": []}, name=f"sweep-{name}-{i + 1}-{j}") for j in range(_SLOTS)]
            for j, src in enumerate(srcs):
                fig.line("x", "y", source=src, line_color=EXTRA_COLORS[name], line_dash=SIGMA_DASHES[j], line_width=1.8)
            extra_lines[name] = srcs
        self._extra_lines.append(extra_lines)
        self._lines.append(lines)
        self._points.append(points)
        self._nu_marks.append(mark)
        self._renderers.append(items)
        return fig

    # ---- updates -----------------------------------------------------------------------------------
    def _update_layout(self, *events) -> None:
        """One row of m plots, or two rows for m > 3."""
        m = self.state.m
        per_row = m if m <= 3 else -(-m // 2)
        self._rows[0].objects = self._panes[:per_row]
        self._rows[1].objects = self._panes[per_row:m]

    def _update_curves(self, *events) -> None:
        curves = self.state.sweep.curves
        with pn.io.hold():
            for i in range(M_MAX):
                for j in range(_SLOTS):
                    have = curves is not None and i < curves.m and j < len(curves.sigmas)
                    y: np.ndarray | list[float] = _positive(curves.ratios[j, :, i]) if have else []
                    self._lines[i][j].data = {"x": curves.nu_over_beta if have else [], "y": y}
                    item = self._renderers[i][j]
                    item.visible = have
                    if have:
                        item.label = value(f"σ = {curves.sigmas[j]:g}")
                self._update_extra(i, curves)
            names = [n for n in _EXTRA_CURVES if curves is not None and n in curves.extra]
            self._extra_legend.object = (
                ""
                if not names
                else (
                    "Other filters, theory (line style = σ as in each legend): "
                    + " &nbsp; ".join(
                        f"<span style='color:{EXTRA_COLORS[n]};font-weight:bold'>&#9472;&#9472;</span> {LABELS[n]}"
                        + (" (flat: fixed gain)" if n != "isl_model" else "")
                        for n in names
                    )
                )
            )

    def _update_extra(self, i: int, curves) -> None:
        """Curves of the extra filters in plot i (empty when not selected)."""
        extra = {} if curves is None or i >= curves.m else curves.extra
        for name in _EXTRA_CURVES:
            have = name in extra
            for j, src in enumerate(self._extra_lines[i][name]):
                if have and j < len(curves.sigmas):
                    src.data = {"x": curves.nu_over_beta, "y": _positive(extra[name][j, :, i])}
                elif len(src.data["x"]):
                    src.data = {"x": [], "y": []}

    def _update_points(self, *events) -> None:
        pts = self.state.sweep.points
        with pn.io.hold():
            for i in range(M_MAX):
                for j in range(_SLOTS):
                    if pts is not None and i < pts.m and j < len(pts.sigmas):
                        data = {
                            "x": pts.nu_over_beta,
                            "y": _positive(pts.ratio[j, :, i]),
                            "lower": _positive(np.maximum(pts.low[j, :, i], 1e-3)),
                            "upper": _positive(pts.high[j, :, i]),
                        }
                    else:
                        data = {"x": [], "y": [], "lower": [], "upper": []}
                    self._points[i][j].data = data

    def _update_nu(self, *events) -> None:
        beta = self.state.beta_effective
        x = self.state.nu / beta if beta > 0 else 1.0
        for mark in self._nu_marks:
            mark.location = x

    # ---- controls ----------------------------------------------------------------------------------
    def _controls(self) -> pn.Column:
        s = self.state
        sigmas = list_box(s, "sweep_sigmas", pn.widgets.TextInput(label="σ values (comma separated)", width=px(s, 220)))
        horizon = log_slider(s, "sweep_horizon")
        horizon.width = 260
        run, cancel, progress = job_buttons(
            s.sweep.param.busy,
            s.sweep.param.progress,
            "Simulate points",
            s.sweep.simulate,
            s.sweep.cancel,
            width=150,
            below_label=False,
            scale=text_scale(s),
        )
        recommend = pn.widgets.Button(
            label="Use recommended ν",
            color="success",
            width=px(self.state, 180),
            disabled=pn.bind(lambda busy, a: busy or a == 0.0, s.sweep.param.busy, s.param.alpha),
        )
        recommend.on_click(lambda e: s.sweep.recommend())
        note = pn.pane.Markdown(
            pn.bind(
                self._note, s.sweep.param.note, s.sweep.param.curves_note, s.sweep.param.points, s.sweep.param.curves
            ),
            margin=(0, 10),
        )
        return pn.Column(
            pn.FlexBox(
                field(s, "sweep_sigmas", sigmas),
                field(s, "sweep_horizon", horizon),
                run,
                cancel,
                progress,
                recommend,
                flex_wrap="wrap",
                sizing_mode="stretch_width",
            ),
            note,
            sizing_mode="stretch_width",
        )

    def _note(self, sweep_note: str, curves_note: str, points, curves) -> str:
        parts = [p for p in (curves_note, sweep_note) if p]
        if curves is None and not curves_note:
            parts.insert(0, "Computing the theory curves …")
        if curves is not None and curves.alpha == 0.0:
            if len(curves.sigmas) > 1 and np.allclose(curves.ratios, curves.ratios[:1], rtol=1e-9, equal_nan=True):
                parts.append(
                    "The theory curves of every σ coincide (drawn on top of each other): at α = 0 the "
                    "ratio depends on ν/β only, not on σ."
                )
            parts.append("*Use recommended ν* needs α > 0: its search is over paper A's β = w·√(2α).")
        if points is not None:
            kbf = ", ".join(
                f"σ = {s:g}: "
                + " / ".join(
                    f"{r:.2f} [{lo:.2f}, {hi:.2f}]"
                    for r, lo, hi in zip(points.kbf[j], points.kbf_low[j], points.kbf_high[j], strict=True)
                )
                for j, s in enumerate(points.sigmas)
            )
            parts.append(f"Check — Kalman–Bucy measured ratios (should be 1 within the interval): {kbf}.")
        return "  \n".join(parts)

    def __panel__(self):
        intro = pn.pane.Markdown(
            "ISL filter's RMSE ratio š<sub>i</sub>/s<sub>i</sub> against ν/β for the current α, β and m. "
            "**Lines: theory** (statistical linearization; it under-predicts where the filter loses lock at "
            "small ν). **Dots: simulation** with 95 % intervals (on demand). Red line: the current ν.",
            margin=(0, 10),
            styles={"font-size": TEXT_FONT},
        )
        return pn.Column(intro, self._controls(), self._extra_legend, *self._rows, sizing_mode="stretch_width")
