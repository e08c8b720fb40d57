"""Trajectories view (paper A, Fig. 3; paper B, Fig. 2): one plot per coordinate X_i, shared time axis.

Per coordinate i: the truth X_i (black), the Kalman–Bucy estimate X̂_i (green), the ISL estimate X̌_i
(blue) and the tube X̂_i ± 3 s_i (dashed green), s_i = √Δ_ii the optimal RMSE (A.29). The six figures are
built once; a new run only replaces the data of their ColumnDataSources (decimated traces, float32) and the
tube offsets (a ``Dodge`` transform of X̂_i by ±3 s_i, so the tube costs no extra data). Extra filters of the
run (:mod:`app.extras`) are drawn by :class:`app.views.overlay.Overlay`, one colour each.
"""
from __future__ import annotations

import numpy as np
import panel as pn
import param
from bokeh.core.properties import field, value
from bokeh.models import ColumnDataSource, Dodge, Legend, LegendItem, Range1d, Title
from bokeh.plotting import figure
from panel.viewable import Viewer

from isl_core import M_MAX

from ..state import COORDINATES, AppState
from .overlay import LEGEND_ROW, Overlay
from .style import ISL, KBF, SUBSCRIPT, TRUTH, styled

__all__ = ["TrajectoriesView", "plot_height"]

LEGEND_HEIGHT = 80  #: the first plot carries the run's summary and the legend (two rows) above its frame
_EMPTY = {"t": np.zeros(0, np.float32), "y": np.zeros(0, np.float32)}


def plot_height(m: int) -> int:
    """Height of each of the m stacked plots (about 720 px in all, within 170…330 px each)."""
    return int(min(max(720 // m, 170), 330))


def _y_limits(series: dict, tube: float) -> tuple[float, float]:
    """y range showing every trace and the tube X̂ ± ``tube``, with 4 % margins."""
    lo = min(float(series[n][1].min()) for n in series) if len(series["kbf"][1]) else -1.0
    hi = max(float(series[n][1].max()) for n in series) if len(series["kbf"][1]) else 1.0
    lo = min(lo, float(series["kbf"][1].min()) - tube)
    hi = max(hi, float(series["kbf"][1].max()) + tube)
    pad = 0.04 * (hi - lo) or 1.0
    return lo - pad, hi + pad


def _set_range(r: Range1d, start: float, end: float) -> None:
    """Fixed ranges computed here: the browser has nothing to compute and nothing to send back."""
    r.update(start=start, end=end, reset_start=start, reset_end=end)


class TrajectoriesView(Viewer):
    """m stacked trajectory plots; data updated in place when the state's traces change."""

    state = param.ClassSelector(class_=AppState)

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._x_range = Range1d(0.0, 1.0)  # shared: pan or zoom one plot's time axis and all follow
        self._sources: list[dict[str, ColumnDataSource]] = []
        self._dodges: list[tuple[Dodge, Dodge]] = []
        self._overlay = Overlay()
        self._figures = [self._figure(i) for i in range(M_MAX)]
        self._panes = [pn.pane.Bokeh(f, sizing_mode="stretch_width", margin=(0, 5)) for f in self._figures]
        self._column = pn.Column(sizing_mode="stretch_width")
        self.state.param.watch(self._update, ["traces"])
        self._update()

    def _figure(self, i: int) -> figure:
        k = str(i + 1).translate(SUBSCRIPT)
        fig = styled(figure(
            x_range=self._x_range, y_range=Range1d(-1.0, 1.0), height=plot_height(3), sizing_mode="stretch_width",
            title=f"X{k} — {COORDINATES[i]}", tools="xpan,xwheel_zoom,box_zoom,reset,save",
            active_scroll=None, output_backend="canvas",
        ))
        fig.yaxis.axis_label = f"{COORDINATES[i]} X{k}"
        src = {name: ColumnDataSource(dict(_EMPTY), name=f"traj-{i + 1}-{name}") for name in ("truth", "kbf", "isl")}
        up, down = Dodge(value=0.0), Dodge(value=0.0)
        tube = {"source": src["kbf"], "line_color": KBF, "line_dash": "dashed", "line_width": 1.3, "line_alpha": 0.9}
        tube_lines = [fig.line("t", field("y", up), **tube), fig.line("t", field("y", down), **tube)]
        truth = fig.line("t", "y", source=src["truth"], line_color=TRUTH, line_width=1.4)
        kbf = fig.line("t", "y", source=src["kbf"], line_color=KBF, line_width=1.8)
        isl = fig.line("t", "y", source=src["isl"], line_color=ISL, line_width=1.8)
        if i == 0:  # the run's parameters and one legend for all plots, drawn on the canvas (no page re-layout)
            self._summary = Title(text="", text_font_size="10.5pt", text_font_style="italic")
            fig.add_layout(self._summary, "above")
            items = [(f"X{k} signal", [truth]), (f"X̂{k} Kalman–Bucy (knows σ)", [kbf]),
                     (f"X̌{k} ISL (σ unknown)", [isl]), (f"X̂{k} ± 3 s{k} (optimal RMSE)", tube_lines)]
            legend = Legend(items=[LegendItem(label=value(text), renderers=r) for text, r in items],
                            orientation="horizontal", ncols=2, label_text_font_size="11pt", click_policy="hide",
                            padding=2, margin=2, spacing=14)  # two rows: fits a plot ≥ 450 px wide
            fig.add_layout(legend, "above")
        self._overlay.add(fig, i, k)
        self._sources.append(src)
        self._dodges.append((up, down))
        return fig

    def _update(self, *events) -> None:
        traces, run = self.state.traces, self.state.run
        m = 0 if traces is None else len(traces.series)
        with pn.io.hold():
            if run is not None:
                _set_range(self._x_range, 0.0, run.T)
            extra_row = self._overlay.show([] if run is None else [tr.name for tr in run.tracks[2:]])
            for i, fig in enumerate(self._figures):
                if i < m:
                    for name, src in self._sources[i].items():
                        t, y = traces.series[i][name]
                        src.data = {"t": t, "y": y}
                    self._overlay.update(i, traces.series[i])
                    up, down = self._dodges[i]
                    up.value, down.value = 3.0 * float(run.s[i]), -3.0 * float(run.s[i])
                    _set_range(fig.y_range, *_y_limits(traces.series[i], 3.0 * float(run.s[i])))
                    fig.height = plot_height(m) + (LEGEND_HEIGHT + LEGEND_ROW * extra_row if i == 0 else 0)
                    fig.xaxis.axis_label = "time t" if i == m - 1 else None
                elif len(self._sources[i]["kbf"].data["t"]):
                    for src in self._sources[i].values():
                        src.data = dict(_EMPTY)
                    self._overlay.update(i, None)
            self._summary.text = self._header_text()
            if len(self._column.objects) != m:  # only the m plots in the page: hidden ones would still be laid out
                self._column.objects = self._panes[:m]

    def _header_text(self) -> str:
        run = self.state.run
        if run is None:
            return "No run yet."
        mo = run.model
        return (f"m = {mo.m}, α = {mo.alpha:.4g}, β = {mo.beta:.4g}, σ = {mo.sigma:.4g}, ν = {run.nu:.4g} "
                f"(ν/β = {run.nu / mo.beta:.3g}) · T = {run.T:.4g} = {run.T * run.r_min:.3g}/r_min · N = {run.N:,}")

    def __panel__(self):
        return self._column
