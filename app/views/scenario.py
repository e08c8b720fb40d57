"""Scenario view: every filter's rolling RMSE ratio to the clairvoyant Kalman filter in time, σ(t) and σ̂(t) below it,
the worst cases, and the who-wins map (:mod:`app.scenario`).

Two linked plots share the time axis: the ratios (log scale, 95 % bands over the runs; 1 is the clairvoyant filter's
own level) and σ(t) with the σ̂(t) of each filter that learns σ. A dashed line marks the σ change. The worst-case
table and the map's cells are HTML tables; the map colours each cell by its winner and marks a tie. Figures are built
once and updated in place.
"""
from __future__ import annotations

import html
import math

import numpy as np
import panel as pn
import param
from bokeh.core.properties import value
from bokeh.models import ColumnDataSource, Legend, LegendItem, LogTicker, Range1d, Span
from bokeh.plotting import figure
from panel.viewable import Viewer

from isl_core.scenario.map import AXIS_LABELS

from ..colors import EXTRA_COLORS, ISL, KBF, text_on, tint
from ..scenario import BURN, CHOICE_LABELS, PRESETS, Picture
from ..state import AppState
from .fields import field
from .filters_panel import bind
from .filters_panel import number as number_box
from ..text import R_MIN, R_MIN_HTML, per_r_min_html
from .style import TEXT_FONT, job_buttons, px, ratio_axis, styled, text_scale

__all__ = ["SCENARIO_COLORS", "ScenarioView", "map_html", "worst_html"]

#: every filter of a picture; the clairvoyant reference in grey, the two filters paper A compares as everywhere
SCENARIO_COLORS = {"clairvoyant": "#6b6b6b", "kbf": KBF, "isl": ISL, "vb": "#7b3294", "kbf_robust": "#d6604d",
                   "isl_minimax": "#7b9be0", "imm": "#1b7837",
                   **{k: v for k, v in EXTRA_COLORS.items() if k not in ("kbf",)}}
_SHORT = {"clairvoyant": "clairvoyant", "kbf": "KBF σ(0)", "isl": "ISL", "kbf_adaptive": "adaptive", "vb": "VB",
          "kbf_robust": "robust", "isl_minimax": "ISL minimax", "isl_model": "ISL model-aware", "imm": "IMM"}
_CSS = """
table.isl-scn { border-collapse: collapse; font-size: var(--isl-table-font, 14px); margin: 4px 0 8px 0; }
table.isl-scn th, table.isl-scn td { padding: 4px 8px; text-align: right; border-bottom: 1px solid #ddd; }
table.isl-scn td:first-child, table.isl-scn th:first-child { text-align: left; }
table.isl-scn .ci { display: block; font-size: var(--isl-tag-font, 12px); color: #555; }
table.isl-scn .best { font-weight: 700; }
table.isl-scn td.cell { text-align: center; }
table.isl-scn td.tie { outline: 2px dashed #444; outline-offset: -3px; }
"""


def _finite(a: np.ndarray) -> np.ndarray:
    """Positive finite values kept, the rest NaN (a gap on a log axis)."""
    return np.where(np.isfinite(a) & (a > 0), a, np.nan)


def worst_html(pic: Picture | None) -> str:
    """Per filter: the worst rolling ratio after the burn-in, with its bootstrap interval (bold: the best filter that
    does not know σ(t))."""
    if pic is None:
        return ""
    run = pic.average.run
    if pic.worst is None:
        return ("<p>No worst case: it needs 2 runs or more and a horizon longer than "
                f"{per_r_min_html(BURN)} + the window.</p>")
    point, low, high = pic.worst
    best = 1 + int(np.argmin(np.where(np.isfinite(point[1:]), point[1:], np.inf)))
    rows = []
    for f, label in enumerate(run.labels):
        cell = "diverged" if not math.isfinite(point[f]) else (
            f"<span{' class=best' if f == best else ''}>{point[f]:.3g}</span>"
            f"<span class='ci'>[{low[f]:.3g}, {high[f]:.3g}]</span>")
        rows.append(f"<tr><td>{html.escape(label)}</td><td>{cell}</td></tr>")
    head = (f"<tr><th>filter</th><th>worst ratio after {per_r_min_html(BURN)}<span class='ci'>simulated, 95 % bootstrap "
            "interval</span></th></tr>")
    return f"<table class='isl-scn'>{head}{''.join(rows)}</table>"


def map_html(res) -> str:
    """The who-wins map: a cell per swept value (and per window since the step), coloured by its winner, with the
    margin over the runner-up; a light cell with a dashed border, marked "≈", is a tie."""
    if res is None:
        return "<p>No map yet: press <b>Compute map</b>.</p>"
    head = "".join(f"<th>{x:g}</th>" for x in res.x)
    rows = []
    for r, t in enumerate(res.rows):
        label = "" if math.isnan(t) else f"{t:+.3g}"
        cells = []
        for c in range(len(res.x)):
            name = res.filters[res.winner[r, c]]
            tie = bool(res.tie[r, c])
            # a winner on its colour, a tie on a light shade of it with a dashed border: text at ≥ 4.5 : 1 on both
            back = tint(SCENARIO_COLORS[name], 0.3) if tie else SCENARIO_COLORS[name]
            ink = text_on(back)
            cells.append(f"<td class='cell{' tie' if tie else ''}' style='background:{back};color:{ink}' "
                         f"title='{html.escape(res.labels[res.winner[r, c]])}'>{'≈ ' if tie else ''}"
                         f"{html.escape(_SHORT[name])}<span class='ci' style='color:{ink}'>×{res.margin[r, c]:.2f}"
                         "</span></td>")
        rows.append(f"<tr><td>{label}</td>{''.join(cells)}</tr>")
    corner = f"time since the step (1/{R_MIN_HTML}) \\ " if res.kind == "sigma_step" else ""
    return (f"<table class='isl-scn'><tr><th>{corner}{html.escape(AXIS_LABELS[res.kind])}</th>{head}</tr>"
            f"{''.join(rows)}</table>")


def _relabel(item: LegendItem, label: str) -> None:
    """``item``'s text set to ``label`` (no change sent when it already reads so)."""
    if item.label != value(label):
        item.label = value(label)


class ScenarioView(Viewer):
    """Inputs, the two linked time plots, the worst cases and the who-wins map (module docstring)."""

    state = param.ClassSelector(class_=AppState)

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._ratio_src = ColumnDataSource({"t": []}, name="scenario-ratio")
        self._sigma_src = ColumnDataSource({"t": []}, name="scenario-sigma")
        self._ratio_fig, self._sigma_fig = self._figures()
        self._legend_items: dict[str, LegendItem] = {}
        self._worst = pn.pane.HTML("", stylesheets=[_CSS], margin=(0, 10))
        self._map = pn.pane.HTML(map_html(None), stylesheets=[_CSS], margin=(0, 10))
        self._change = Span(location=0.0, dimension="height", line_color="#888", line_dash="dashed", visible=False)
        self._ratio_fig.add_layout(self._change)
        self.state.param.watch(self._update, ["scenario"])
        self.state.param.watch(lambda e: setattr(self._map, "object", map_html(e.new)), ["sc_map_result"])
        self.state.want_scenario()
        self._update()

    def _figures(self):
        scale = text_scale(self.state)
        ratio = styled(figure(y_axis_type="log", height=380, sizing_mode="stretch_width", x_range=Range1d(0, 1),
                              title="RMSE ratio to the clairvoyant Kalman filter (simulated, rolling window)",
                              tools="pan,xwheel_zoom,box_zoom,reset,save"), scale)
        ratio.yaxis.axis_label = "RMSE / clairvoyant sd (worst i)"
        ratio_axis(ratio, scale)
        ratio.add_layout(Span(location=1.0, dimension="width", line_color="#888", line_width=1))
        sigma = styled(figure(y_axis_type="log", height=220, sizing_mode="stretch_width", x_range=ratio.x_range,
                              title="σ(t) and the σ̂(t) of the filters that learn it", tools="pan,xwheel_zoom,reset"),
                       scale)
        sigma.xaxis.axis_label = f"time t, in units of 1/{R_MIN} at σ(0)"
        sigma.yaxis.axis_label = "σ"
        sigma.yaxis.ticker = LogTicker(mantissas=[1, 2, 5])  # labels at every decade's 1, 2, 5
        for fig in (ratio, sigma):
            fig.add_layout(Legend(items=[], location="top_left", label_text_font_size=f"{10 * scale:.3g}pt",
                                  click_policy="hide"),
                           "right")
        return ratio, sigma

    def _update(self, *events) -> None:
        pic = self.state.scenario
        self._worst.object = worst_html(pic)
        if pic is None:
            return
        roll, run = pic.rolling, pic.average.run
        with pn.io.hold():
            data = {"t": roll.t}
            for f, name in enumerate(run.names):  # a diverged filter's windows (inf) are left blank
                data[name] = _finite(roll.ratio[:, f])
                data[f"{name}_low"] = _finite(roll.low[:, f])
                data[f"{name}_high"] = _finite(roll.high[:, f])
            self._ratio_src.data = data
            sig = {"t": roll.t, "sigma": roll.sigma}
            for k, name in enumerate(pic.average.learning):
                sig[name] = _finite(roll.sigma_hat[:, k])
            self._sigma_src.data = sig
            self._draw(run, pic.average.learning)
            self._ratio_fig.x_range.update(start=0.0, end=float(run.t[-1] * run.r_min))
            knots = pic.request.scenario.sigma_knots
            self._change.update(location=knots[0][0] if knots else 0.0, visible=bool(knots))

    def _draw(self, run, learning) -> None:
        """Glyphs for filters not drawn yet (the set of filters is the same in every picture), and every legend entry
        labelled as this picture's run labels it (σ(0) and ν are in the labels: they change with the picture)."""
        legend = self._ratio_fig.legend[0]
        for name, label in zip(run.names, run.labels, strict=True):
            if name in self._legend_items:
                _relabel(self._legend_items[name], label)
                continue
            color = SCENARIO_COLORS[name]
            band = self._ratio_fig.varea("t", f"{name}_low", f"{name}_high", source=self._ratio_src, color=color,
                                         fill_alpha=0.12)
            line = self._ratio_fig.line("t", name, source=self._ratio_src, color=color, line_width=2,
                                        line_dash="dashed" if name == "clairvoyant" else "solid")
            self._legend_items[name] = LegendItem(label=value(label), renderers=[line, band])
            legend.items = [*legend.items, self._legend_items[name]]
        sigma_legend = self._sigma_fig.legend[0]
        if not sigma_legend.items:
            items = [LegendItem(label=value("σ(t), simulated"), renderers=[
                self._sigma_fig.line("t", "sigma", source=self._sigma_src, color="#000", line_width=2)])]
            for name in learning:
                items.append(LegendItem(label=value(""), renderers=[
                    self._sigma_fig.line("t", name, source=self._sigma_src, color=SCENARIO_COLORS[name],
                                         line_width=2)]))
            sigma_legend.items = items
        for item, name in zip(sigma_legend.items[1:], learning, strict=True):
            _relabel(item, f"σ̂: {run.labels[run.names.index(name)]}")

    def _controls(self) -> pn.Column:
        s = self.state
        p = s.param

        def number(name: str, width: int = 150, **kw):
            return field(s, name, number_box(s, name, width=px(s, width), **kw))

        def choice(name: str, width: int = 130):
            options = {CHOICE_LABELS[name][v]: v for v in p[name].objects}
            return field(s, name, bind(s, name, pn.widgets.Select(
                label=p[name].label, options=options, width=px(s, width), description=p[name].doc)))

        preset = pn.widgets.Select(label="scenario preset (the table's columns)", options=["—", *PRESETS], width=px(self.state, 260))

        def pick(event) -> None:
            if event.new != "—":
                s.apply_scenario_preset(event.new)
                preset.value = "—"
        preset.param.watch(pick, "value")
        download = pn.widgets.FileDownload(callback=s.scenario_csv, filename="isl_scenario.csv",
                                           label="Download (CSV)", color="success", variant="outline", width=px(self.state, 150),
                                           margin=(24, 10, 0, 10))
        spinner = pn.indicators.LoadingSpinner(value=p.scenario_busy, visible=p.scenario_busy, size=20,
                                               margin=(30, 10))
        row = dict(flex_wrap="wrap", sizing_mode="stretch_width")
        return pn.Column(
            pn.FlexBox(preset, choice("sc_change"), number("sc_change_at"), number("sc_sigma_after", 120), **row),
            pn.FlexBox(choice("sc_noise"), number("sc_dof", 190), number("sc_outlier_rate", 130),
                       number("sc_outlier_scale", 130), number("sc_sensor", 190), **row),
            pn.FlexBox(number("sc_horizon", 190), number("sc_window", 170), number("sc_runs", 120), download,
                       spinner, **row),
            pn.pane.Markdown(p.sc_preset_note, margin=(0, 10)), pn.pane.Markdown(p.scenario_note, margin=(0, 10)),
            sizing_mode="stretch_width")

    def _map_controls(self) -> pn.Column:
        s = self.state
        p = s.param
        kind = field(s, "sc_map", bind(s, "sc_map", pn.widgets.Select(
            label=p.sc_map.label, options={CHOICE_LABELS["sc_map"][v]: v for v in p.sc_map.objects}, width=px(self.state, 170))))
        seeds = field(s, "sc_map_seeds", number_box(s, "sc_map_seeds", width=px(self.state, 110)))
        run, cancel, progress = job_buttons(p.sc_map_busy, p.sc_map_progress, "Compute map", s.compute_map,
                                            s.cancel_map, width=140, scale=text_scale(s))
        return pn.Column(pn.FlexBox(kind, seeds, run, cancel, progress, flex_wrap="wrap", sizing_mode="stretch_width"),
                         pn.pane.Markdown(p.sc_map_note, margin=(0, 10)), sizing_mode="stretch_width")

    def __panel__(self):
        intro = pn.pane.Markdown(
            "Beyond paper A's model: σ that **changes** (σ is σ(0), the value before the change), **heavy-tailed** "
            "noise, a **coarse sensor**. Every filter runs on the same noise and is compared with the *clairvoyant* "
            "Kalman filter, which knows σ(t), the noise's variance and the sensor: its ratio is 1 up to sampling "
            "error. The ISL filters use ν; the adaptive, variational-Bayes and robust filters learn σ over "
            "[σ min, σ max] from its geometric middle.", margin=(0, 10), styles={"font-size": TEXT_FONT})
        map_intro = pn.pane.Markdown(
            "**Who wins where** — per cell, the filter with the lowest ratio to the clairvoyant one (max over "
            "coordinates, mean square over the runs) and its margin over the runner-up; a light cell with a dashed "
            "border, marked ≈, is a tie (the margin's 95 % lower bound over the runs is ≤ 1). Paper A's model at this "
            "α, m and w, σ(0) = 20 (the command line's `isl scenario --map` computes the same map).", margin=(10, 10, 0, 10),
            styles={"font-size": TEXT_FONT})
        return pn.Column(intro, self._controls(),
                         pn.pane.Bokeh(self._ratio_fig, margin=5, sizing_mode="stretch_width"),
                         pn.pane.Bokeh(self._sigma_fig, margin=5, sizing_mode="stretch_width"),
                         self._worst, map_intro, self._map_controls(), self._map, sizing_mode="stretch_width")
