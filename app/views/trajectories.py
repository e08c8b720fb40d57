"""Trajectories view (paper A, Fig. 3; paper B, Fig. 2): one plot per coordinate X_i, shared time axis.

Per coordinate i: the truth X_i (black), the Kalman–Bucy estimate X̂_i (green), the ISL estimate X̌_i (blue) and the
tube X̂_i ± 3 s_i (dashed green), s_i = √Δ_ii the optimal RMSE (A.29). The six figures are built once; a new run only
replaces the data of their ColumnDataSources (decimated traces, float32) and the tube offsets. The tube is a ``Band``
whose edges are X̂_i moved by ±3 s_i in the browser, in float64 (:data:`EDGE`): it costs no extra data, and as an
annotation the browser redraws it without the per-glyph work (spatial index, selection view) that two extra line glyphs
cost on every update. BokehJS recomputes a band's edges when its own properties or its source change, not when a
transform it reads changes: a run whose data arrived before its new offsets kept the previous run's tube (after a
preset, σ = 200's run was drawn inside σ = 20's ±3 s_i). So each offset tells its band to recompute in the browser
(:data:`RECOMPUTE_BAND`) whatever order the run's changes arrive in — and so does each source a band may stand on
(X̂_i's, or the zero line's in the error view): BokehJS listens to the source a band had when it was first drawn, not to
one it is moved to later (a page opened in the error view, switched to the signal, then given new noise, kept the old
noise's tube around the new X̂_i). Extra filters of the run (:mod:`app.extras`) are drawn by
:class:`app.views.overlay.Overlay`, one colour each.

The **error view** (a switch above the plots) draws each filter's error X̂_i − X_i, X̌_i − X_i, … instead, with
the band ±3 s_i around 0 and the signal as the zero line: at high orders X_1 spans ±10⁶ and the tube is invisible
beside it, while the errors show at their own scale. The errors are decimated by the core like the estimates.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import panel as pn
import param
from bokeh.core.properties import field, value
from bokeh.models import Band, ColumnDataSource, CustomJS, CustomJSTransform, Dodge, Legend, LegendItem, Range1d, Title
from bokeh.plotting import figure
from panel.viewable import Viewer

from isl_core import M_MAX

from ..pipeline import COORDINATES
from ..state import AppState
from ..text import num, per_r_min
from .overlay import KEY_DATA, Overlay, follow
from .style import ISL, KBF, SUBSCRIPT, TRUTH, line, styled, text_scale

__all__ = ["EDGE", "RECOMPUTE_BAND", "TrajectoriesView", "plot_height"]

#: the traces' line styles (bokeh Line properties)
_TRUTH: dict[str, Any] = {"line_color": TRUTH, "line_width": 1.4}
_KBF: dict[str, Any] = {"line_color": KBF, "line_width": 1.8}
_ISL: dict[str, Any] = {"line_color": ISL, "line_width": 1.8}
_TUBE: dict[str, Any] = {"line_color": KBF, "line_dash": "dashed", "line_width": 1.3, "line_alpha": 0.9}

SUMMARY_HEIGHT = 30  #: the first plot carries the run's summary above its frame
LEGEND_ROW = 30  #: height of one row of the legend (two entries a row)
_EMPTY = {"t": np.zeros(0, np.float32), "y": np.zeros(0, np.float32)}
#: a tube edge in the browser: the line's values plus the offset ``d.value`` (a ``Dodge`` the server sets), in float64.
#: BokehJS's own ``Dodge`` computes in the type of the line's array: in float32 an edge near |X̂_i| is off by up to half
#: a float32 spacing there (2⁻²⁴ |X̂_i|) — at m = 6 with β = 1000, |X̂₁| reaches 7.6·10¹⁰ and that was 4096 beside a
#: 3 s₁ of 5527. Offsets added in float64 to the drawn line are exact, and the data stay float32.
EDGE = """const v = d.value, out = new Float64Array(xs.length);
for (let k = 0; k < xs.length; k++) out[k] = xs[k] + v;
return out;"""
#: run in the browser when a tube offset changes: the band re-reads its edges (y ± the new offset) and repaints
RECOMPUTE_BAND = "band.change.emit()"


def _legend_figure(row: float) -> figure:
    """A figure holding only the legend: its glyphs are empty lines, nothing in it changes with a run.

    The legend sits in its own figure above the plots, not in the first plot: a run redraws every plot, and a
    legend inside one is redrawn with it. Its entries' glyphs are unseen lines of this figure, not the plotted
    lines (see :func:`app.views.overlay.follow`), so nothing a run changes is reachable from the legend.
    """
    fig = figure(
        height=round(2 * row) + 8,
        sizing_mode="stretch_width",
        toolbar_location=None,
        x_axis_type=None,
        y_axis_type=None,
        x_range=Range1d(0, 1),
        y_range=Range1d(0, 1),
        outline_line_color=None,
        min_border=0,
        min_border_left=70,
    )
    fig.grid.visible = False
    return fig


def plot_height(m: int) -> int:
    """Height of each of the m stacked plots (about 720 px in all, within 170…330 px each)."""
    return int(min(max(720 // m, 170), 330))


SIGNAL, ERRORS = "Signal and estimates", "Errors (estimate − signal)"  #: the view switch's two options
#: legend texts: (signal view, error view)
KEY_LABELS = {
    "truth": ("Xᵢ signal", "0 (no error)"),
    "kbf": ("X̂ᵢ Kalman–Bucy (knows σ)", "X̂ᵢ − Xᵢ Kalman–Bucy"),
    "isl": ("X̌ᵢ ISL (σ unknown)", "X̌ᵢ − Xᵢ ISL"),
    "tube": ("X̂ᵢ ± 3 sᵢ (optimal RMSE)", "± 3 sᵢ"),
}


def shown_series(series: dict, errors: bool, T: float) -> dict:
    """The traces one plot draws: per name (``truth``, ``kbf``, ``isl``, extra filters) the decimated ``(t, y)`` of
    the estimates — or, with ``errors``, of the errors (``error:<name>`` in ``series``) and a zero line for the
    signal, which the band ±3 s_i is drawn around."""
    if not errors:
        return {n: v for n, v in series.items() if not n.startswith("error:")}
    zero = (np.array([0.0, T], np.float32), np.zeros(2, np.float32))
    return {"truth": zero, **{n[len("error:") :]: v for n, v in series.items() if n.startswith("error:")}}


def _y_limits(series: dict, tube: float, around_zero: bool = False) -> tuple[float, float]:
    """y range showing every trace and the tube (X̂ ± ``tube``, or ±``tube`` around 0), with 4 % margins."""
    lo = min(float(series[n][1].min()) for n in series) if len(series["kbf"][1]) else -1.0
    hi = max(float(series[n][1].max()) for n in series) if len(series["kbf"][1]) else 1.0
    center = series["truth"] if around_zero else series["kbf"]
    lo = min(lo, float(center[1].min()) - tube)
    hi = max(hi, float(center[1].max()) + tube)
    pad = 0.04 * (hi - lo) or 1.0
    return lo - pad, hi + pad


def _set_range(r: Range1d, start: float, end: float) -> None:
    """Fixed ranges computed here: the browser has nothing to compute and nothing to send back.

    Untouched when it already shows exactly these limits (the time axis after a σ or ν move): no change to send.
    """
    if (r.reset_start, r.reset_end) != (start, end) or (r.start, r.end) != (r.reset_start, r.reset_end):
        r.update(start=start, end=end, reset_start=start, reset_end=end)


class TrajectoriesView(Viewer):
    """m stacked trajectory plots; data updated in place when the state's traces change."""

    state = param.ClassSelector(class_=AppState)

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._x_range = Range1d(0.0, 1.0)  # shared: pan or zoom one plot's time axis and all follow
        self._sources: list[dict[str, ColumnDataSource]] = []
        self._dodges: list[tuple[Dodge, Dodge]] = []
        self._key_figure = _legend_figure(LEGEND_ROW * self.scale)
        self._keys = self._legend_keys()
        self._followers = {name: follow(item.renderers[0]) for name, item in self._keys.items()}
        self._overlay = Overlay(self._key_figure)
        # a link's filters: their lines are built with the page
        self._overlay.expect(self.state.baselines.extra_filters)
        self._figures: list[figure] = []
        self._panes: list[pn.pane.Bokeh] = []
        self._bands: list[Band] = []
        self._mode = pn.widgets.RadioButtonGroup(
            options={SIGNAL: "signal", ERRORS: "errors"},
            value=self.state.view,
            margin=(5, 10),
            variant="outline",
            stylesheets=[f":host {{ font-size: {round(14 * self.scale)}px; }}"],
        )
        self._mode.param.watch(lambda event: setattr(self.state, "view", event.new), "value")
        self.state.param.watch(self._on_view, ["view"])
        self._ensure(self.state.m)  # the plots of the coordinates shown; more are built when m grows
        self._legend = Legend(
            items=[*self._keys.values(), *self._overlay.items],
            orientation="horizontal",
            ncols=2,
            label_text_font_size=f"{11 * self.scale:.3g}pt",
            click_policy="hide",
            padding=2,
            margin=2,
            spacing=14,
            location="top_left",
            border_line_alpha=0,
            background_fill_alpha=0,
        )
        self._key_figure.add_layout(self._legend, "center")
        self._key_pane = pn.pane.Bokeh(self._key_figure, sizing_mode="stretch_width", margin=(0, 5))
        self._plots = pn.Column(sizing_mode="stretch_width", margin=0)  # the mode, the legend and the m plots
        self._waiting = pn.Row(
            pn.indicators.LoadingSpinner(value=True, size=28, margin=(4, 10)),
            pn.pane.Markdown("**Simulating the first run …**", margin=(6, 0)),
            sizing_mode="stretch_width",
            margin=(20, 10),
        )
        self._reason = pn.pane.Alert("", alert_type="danger", sizing_mode="stretch_width", margin=(20, 10))
        self._column = pn.Column(self._waiting, self._reason, self._plots, sizing_mode="stretch_width")
        self.state.param.watch(self._update, ["traces"])
        self.state.param.watch(self._placeholder, ["busy", "message"])
        self._update()

    def _ensure(self, m: int) -> None:
        """Plots for coordinates 1..m (each costs Python time to build: only those shown are built)."""
        while len(self._figures) < min(m, M_MAX):
            fig = self._figure(len(self._figures))
            self._figures.append(fig)
            self._panes.append(pn.pane.Bokeh(fig, sizing_mode="stretch_width", margin=(0, 5)))

    def _legend_keys(self) -> dict[str, LegendItem]:
        """The legend's entries for the four traces, each with an unseen line of the same style as its glyph."""

        def empty(**style):
            return self._key_figure.line("t", "y", source=ColumnDataSource(dict(KEY_DATA)), **style)

        keys = {"truth": empty(**_TRUTH), "kbf": empty(**_KBF), "isl": empty(**_ISL), "tube": empty(**_TUBE)}
        return {
            name: LegendItem(label=value(KEY_LABELS[name][self.errors]), renderers=[key]) for name, key in keys.items()
        }

    def _figure(self, i: int) -> figure:
        k = str(i + 1).translate(SUBSCRIPT)
        fig = styled(
            figure(
                x_range=self._x_range,
                y_range=Range1d(-1.0, 1.0),
                height=plot_height(3),
                sizing_mode="stretch_width",
                title=f"X{k} — {COORDINATES[i]}",
                tools="xpan,xwheel_zoom,box_zoom,reset,save",
                active_scroll=None,
                output_backend="canvas",
            ),
            self.scale,
        )
        fig.yaxis.axis_label = f"{COORDINATES[i]} X{k}"
        fig.xaxis.axis_label = "time t"
        src = {name: ColumnDataSource(dict(_EMPTY), name=f"traj-{i + 1}-{name}") for name in ("truth", "kbf", "isl")}
        up, down = Dodge(value=0.0), Dodge(value=0.0)  # the offsets ±3 s_i, added in float64 by EDGE
        edges = [CustomJSTransform(args={"d": d}, func="return x + d.value", v_func=EDGE) for d in (down, up)]
        band = Band(
            base="t", lower=field("y", edges[0]), upper=field("y", edges[1]), source=src["kbf"], fill_alpha=0.0, **_TUBE
        )
        recompute = CustomJS(args={"band": band}, code=RECOMPUTE_BAND)
        up.js_on_change("value", recompute)
        down.js_on_change("value", recompute)
        for stands_on in (src["kbf"], src["truth"]):  # its source in the signal view, and in the error view
            stands_on.js_on_change("data", recompute)
        fig.add_layout(band)
        self._bands.append(band)
        drawn = {
            "tube": band,
            "truth": line(fig, src["truth"], **_TRUTH),
            "kbf": line(fig, src["kbf"], **_KBF),
            "isl": line(fig, src["isl"], **_ISL),
        }
        for name, model in drawn.items():  # a click on a legend entry hides that trace in every plot
            self._followers[name].append(model)
            model.visible = self._keys[name].renderers[0].visible  # a plot built later: as its legend entry says
        if i == 0:  # the run's parameters, drawn on the canvas (no page re-layout)
            self._summary = Title(text="", text_font_size=f"{10.5 * self.scale:.3g}pt", text_font_style="italic")
            fig.add_layout(self._summary, "above")
        self._overlay.add(fig, i)
        self._sources.append(src)
        self._dodges.append((up, down))
        return fig

    def _update(self, *events) -> None:
        traces, run = self.state.traces, self.state.run
        m = 0 if traces is None else len(traces.series)
        self._ensure(m)
        with pn.io.hold():
            if run is not None:
                _set_range(self._x_range, 0.0, run.T)
            extras = self._overlay.show([] if run is None else [tr.name for tr in run.tracks[2:]])
            self._key_figure.height = round((2 + -(-extras // 2)) * LEGEND_ROW * self.scale) + 8
            errors = self.errors
            for i, fig in enumerate(self._figures):
                if i < m:
                    shown = shown_series(traces.series[i], errors, run.T)
                    for name, src in self._sources[i].items():
                        t, y = shown[name]
                        src.data = {"t": t, "y": y}
                    self._overlay.update(i, shown)
                    up, down = self._dodges[i]
                    up.value, down.value = 3.0 * float(run.s[i]), -3.0 * float(run.s[i])
                    self._bands[i].source = self._sources[i]["truth" if errors else "kbf"]
                    k = str(i + 1).translate(SUBSCRIPT)
                    fig.yaxis.axis_label = f"error in X{k}" if errors else f"{COORDINATES[i]} X{k}"
                    _set_range(fig.y_range, *_y_limits(shown, 3.0 * float(run.s[i]), around_zero=errors))
                    fig.height = plot_height(m) + (round(SUMMARY_HEIGHT * self.scale) if i == 0 else 0)
                    fig.xaxis.visible = i == m - 1  # one shared time axis, under the last plot
                elif len(self._sources[i]["kbf"].data["t"]):
                    for src in self._sources[i].values():
                        src.data = dict(_EMPTY)
                    self._overlay.update(i, None)
            self._summary.text = self._header_text()
            self._show(m)
            if run is None:
                self._placeholder()

    @property
    def scale(self) -> float:
        """Font scale of the plots: larger in presenter mode (:func:`app.views.style.text_scale`)."""
        return text_scale(self.state)

    @property
    def errors(self) -> bool:
        """The error view is on."""
        return self.state.view == "errors"

    def _on_view(self, event) -> None:
        # the switch's callback may run on one of the server's threads: the bokeh models change on the session's
        # loop, with its document locked, like every run's outcome (AppState.later)
        if self._mode.value != event.new:
            self._mode.value = event.new
        self.state.later(self._apply_mode)

    def _apply_mode(self) -> None:
        for name, item in self._keys.items():
            item.label = value(KEY_LABELS[name][self.errors])
        self._update()

    def _show(self, m: int) -> None:
        """The column holds the progress indicator, the reason, and the mode, the legend and the plots of the m
        coordinates (a plot not shown would still be laid out); which are visible depends on whether there is a run.

        Changing a column's children re-walks every model of the page on the event loop; switching visibility does
        not. So the children change only when m does: the first run
        shows its plots by visibility, in the page as it was built."""
        m = m or min(self.state.m, M_MAX)
        self._ensure(m)
        if len(self._plots.objects) != m + 2:
            self._plots.objects = [self._mode, self._key_pane, *self._panes[:m]]
        drawn = self.state.run is not None
        self._plots.visible = drawn  # (a Bokeh pane's own `visible` cannot be set once it is in a served page)
        if drawn:
            self._waiting.visible = self._reason.visible = False

    def _placeholder(self, *events) -> None:
        """No run to draw (yet): a progress indicator while the first one is computed, else the reason — never
        empty axes."""
        if self.state.run is not None:
            return
        waiting = self.state.busy or not self.state.message
        if not waiting:
            self._reason.object = f"**Nothing to show.** {self.state.message}"
        self._waiting.visible, self._reason.visible = waiting, not waiting

    def _header_text(self) -> str:
        run = self.state.run
        if run is None:
            return "No run yet."
        mo = run.model
        return (
            f"m = {mo.m}, α = {num(mo.alpha)}, β = {num(mo.beta)}, σ = {num(mo.sigma)}, ν = {num(run.nu)} "
            f"(ν/β = {num(run.nu / mo.beta, 3)}) · T = {num(run.T)} = {per_r_min(run.T * run.r_min, 3)} · "
            f"N = {run.N:,}"
        )

    def __panel__(self):
        return self._column
