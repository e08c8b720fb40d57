"""Scenario view: every filter's rolling RMSE ratio to the clairvoyant Kalman filter in time, σ(t) and σ̂(t) below it,
the period statistic, the tuning curves and the who-wins map (:class:`app.state.ScenarioRoom`).

Two linked plots share the time axis: the ratios (log scale, 95 % bands over the runs; 1 is the clairvoyant filter's
own level) and σ(t) with the σ̂(t) of each filter that learns σ. A dashed line marks the σ change. The worst-case
table and the map's cells are HTML tables; the map colours each cell by its winner and marks a tie. Figures are built
once and updated in place.
"""

from __future__ import annotations

import numpy as np
import panel as pn
import param
from bokeh.core.properties import value
from bokeh.models import ColumnDataSource, DataRange1d, Legend, LegendItem, Range1d, Span
from bokeh.plotting import figure
from panel.viewable import Viewer

from ..state import AppState, declaration
from ..state.scenarios import CHOICE_LABELS, PRESETS
from ..text import R_MIN
from .batch import one_walk
from .fields import field
from .filters_panel import bind
from .filters_panel import number as number_box
from .scenario_tables import SCENARIO_COLORS, TABLE_CSS, map_html, periods_html
from .style import SCENARIO_DASHES, TEXT_FONT, job_buttons, px, ratio_axis, styled, text_scale
from .tuning import TuningView

__all__ = ["ScenarioView"]


def _finite(a: np.ndarray) -> np.ndarray:
    """Positive finite values kept, the rest NaN (a gap on a log axis)."""
    return np.where(np.isfinite(a) & (a > 0), a, np.nan)


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
        self._periods = pn.pane.HTML("", stylesheets=[TABLE_CSS], margin=(0, 10))
        self._map = pn.pane.HTML(map_html(None), stylesheets=[TABLE_CSS], margin=(0, 10))
        self._tuning = TuningView(state=self.state)
        self._change = Span(location=0.0, dimension="height", line_color="#888", line_dash="dashed", visible=False)
        self._ratio_fig.add_layout(self._change)
        self.state.scenarios.param.watch(self._update, ["picture"])
        self.state.scenarios.param.watch(lambda e: setattr(self._map, "object", map_html(e.new)), ["map_result"])
        self.state.scenarios.want()
        self._update()

    def _figures(self):
        scale = text_scale(self.state)
        # the y range fits the lines and their 95 % bands (the bands' renderers join it as they are drawn)
        ratio = styled(
            figure(
                y_axis_type="log",
                height=520,
                sizing_mode="stretch_width",
                x_range=Range1d(0, 1),
                y_range=DataRange1d(renderers=[]),
                title="RMSE ratio to the clairvoyant filter in time, worst coordinate (simulated)",
                tools="pan,xwheel_zoom,box_zoom,reset,save",
            ),
            scale,
        )
        ratio.yaxis.axis_label = "RMSE / clairvoyant sd"  # short: a long label was cut in presenter mode
        ratio_axis(ratio, scale)
        ratio.add_layout(Span(location=1.0, dimension="width", line_color="#888", line_width=1))
        sigma = styled(
            figure(
                y_axis_type="log",
                height=330,
                sizing_mode="stretch_width",
                x_range=ratio.x_range,
                title="σ(t) and the σ̂(t) of the filters that learn it",
                tools="pan,xwheel_zoom,reset",
            ),
            scale,
        )
        sigma.xaxis.axis_label = f"time t, in units of 1/{R_MIN} at σ(0)"
        sigma.yaxis.axis_label = "σ"
        ratio_axis(sigma, scale)  # ticks 1, 2, 5, … far enough apart not to overlap (LogTicker's 15 and 20 did)
        for fig in (ratio, sigma):  # below the plot, in two columns: the filters' labels are long
            fig.add_layout(
                Legend(
                    items=[],
                    orientation="horizontal",
                    ncols=2,
                    click_policy="hide",
                    label_text_font_size=f"{10 * scale:.3g}pt",
                ),
                "below",
            )
        return ratio, sigma

    def _update(self, *events) -> None:
        pic = self.state.scenarios.picture
        self._periods.object = periods_html(pic, None if pic is None else pic.costs)
        if pic is None:
            return
        roll, run = pic.rolling, pic.average.run
        adding = not self._sigma_fig.legend[0].items or any(n not in self._legend_items for n in run.names)
        with pn.io.hold(self._ratio_fig.document), one_walk(self._ratio_fig, adding):
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
            band = self._ratio_fig.varea(
                "t", f"{name}_low", f"{name}_high", source=self._ratio_src, color=color, fill_alpha=0.12
            )
            line = self._ratio_fig.line(
                "t",
                name,
                source=self._ratio_src,
                color=color,
                line_width=2,
                line_dash=SCENARIO_DASHES.get(name, "solid"),  # the pattern tells the filters apart, not only the hue
            )
            self._ratio_fig.y_range.renderers = [*self._ratio_fig.y_range.renderers, line, band]
            self._legend_items[name] = LegendItem(label=value(label), renderers=[line, band])
            legend.items = [*legend.items, self._legend_items[name]]
        sigma_legend = self._sigma_fig.legend[0]
        if not sigma_legend.items:
            items = [
                LegendItem(
                    label=value("σ(t), simulated"),
                    renderers=[self._sigma_fig.line("t", "sigma", source=self._sigma_src, color="#000", line_width=2)],
                )
            ]
            for name in learning:  # labelled here: new models, attached to the document once the drawing ends
                items.append(
                    LegendItem(
                        label=value(f"σ̂: {run.labels[run.names.index(name)]}"),
                        renderers=[
                            self._sigma_fig.line(
                                "t",
                                name,
                                source=self._sigma_src,
                                color=SCENARIO_COLORS[name],
                                line_width=2,
                                line_dash=SCENARIO_DASHES.get(name, "solid"),
                            )
                        ],
                    )
                )
            sigma_legend.items = items
        for item, name in zip(sigma_legend.items[1:], learning, strict=True):
            _relabel(item, f"σ̂: {run.labels[run.names.index(name)]}")

    def _controls(self) -> pn.Column:
        s = self.state
        p = s.scenarios.param

        def number(name: str, width: int = 150, **kw):
            return field(s, name, number_box(s, name, width=px(s, width), **kw))

        def choice(name: str, width: int = 130):
            decl = declaration(name)
            options = {CHOICE_LABELS[name][v]: v for v in decl.objects}
            return field(
                s,
                name,
                bind(
                    s,
                    name,
                    pn.widgets.Select(label=decl.label, options=options, width=px(s, width), description=decl.doc),
                ),
            )

        preset = pn.widgets.Select(
            label="scenario preset (the table's columns)", options=["—", *PRESETS], width=px(self.state, 260)
        )

        def pick(event) -> None:
            if event.new != "—":
                s.scenarios.apply_preset(event.new)
                preset.value = "—"

        preset.param.watch(pick, "value")
        download = pn.widgets.FileDownload(
            callback=s.scenarios.csv,
            filename="isl_scenario.csv",
            label="Download (CSV)",
            color="success",
            variant="outline",
            width=px(self.state, 150),
            margin=(24, 10, 0, 10),
        )
        spinner = pn.indicators.LoadingSpinner(value=p.busy, visible=p.busy, size=20, margin=(30, 10))
        row = dict(flex_wrap="wrap", sizing_mode="stretch_width")
        return pn.Column(
            pn.FlexBox(preset, choice("sc_change"), number("sc_change_at"), number("sc_sigma_after", 120), **row),
            pn.FlexBox(
                choice("sc_noise"),
                number("sc_dof", 190),
                number("sc_outlier_rate", 130),
                number("sc_outlier_scale", 130),
                number("sc_sensor", 190),
                **row,
            ),
            pn.FlexBox(
                number("sc_horizon", 190), number("sc_window", 170), number("sc_runs", 120), download, spinner, **row
            ),
            pn.pane.Markdown(p.preset_note, margin=(0, 10)),
            sizing_mode="stretch_width",
        )

    def _map_controls(self) -> pn.Column:
        s = self.state
        p, decl = s.scenarios.param, declaration("sc_map")
        kind = field(
            s,
            "sc_map",
            bind(
                s,
                "sc_map",
                pn.widgets.Select(
                    label=decl.label,
                    options={CHOICE_LABELS["sc_map"][v]: v for v in decl.objects},
                    width=px(self.state, 170),
                ),
            ),
        )
        seeds = field(s, "sc_map_seeds", number_box(s, "sc_map_seeds", width=px(self.state, 110)))
        run, cancel, progress = job_buttons(
            p.map_busy,
            p.map_progress,
            "Compute map",
            s.scenarios.compute_map,
            s.scenarios.cancel_map,
            width=140,
            scale=text_scale(s),
        )
        return pn.Column(
            pn.FlexBox(kind, seeds, run, cancel, progress, flex_wrap="wrap", sizing_mode="stretch_width"),
            pn.pane.Markdown(p.map_note, margin=(0, 10)),
            sizing_mode="stretch_width",
        )

    def __panel__(self):
        intro = pn.pane.Markdown(
            "Beyond paper A's model: σ that **changes** (σ is σ(0), the value before the change), **heavy-tailed** "
            "noise, a **coarse sensor**. Every filter runs on the same noise and is compared with the *clairvoyant* "
            "Kalman filter, which knows σ(t), the noise's variance and the sensor. The filters that do not know σ(t) "
            "— the ISL filters, the adaptive, variational-Bayes, robust (Huber) and IMM filters — each take the knob "
            "one rule gives them (below: **tuning curves**): tuned for this model once **Tune** has run, else at the "
            "nearest point of the tunings shipped with the package (the table's caption says which); the page's own "
            "ISL filter runs at the ν input.",
            margin=(0, 10),
            styles={"font-size": TEXT_FONT},
        )
        map_intro = pn.pane.Markdown(
            "**Who wins where** — per cell, the filter with the lowest ratio to the clairvoyant one (its worst "
            "coordinate, pooled over the runs, over the periods after the step) and its margin over the runner-up, "
            "paired over the "
            "runs; a light cell with a dashed border, marked ≈, is a tie (the margin's 95 % lower bound is ≤ 1). "
            "Paper A's model at this α, m and w, σ(0) = 20, with the scenario table's tuning (the command line's "
            "`isl scenario --map` computes the same map).",
            margin=(10, 10, 0, 10),
            styles={"font-size": TEXT_FONT},
        )
        bias = pn.pane.Markdown(
            "The rolling ratio takes each window's worst coordinate: it lies above 1 by its noise, the clairvoyant "
            "filter's own line too. The table below is the comparison's statistic: all coordinates over fixed periods, "
            "on which the clairvoyant filter reads 1.",
            margin=(0, 10),
            styles={"font-size": TEXT_FONT},
        )
        settings: list = [intro, self._controls()]
        if self.state.present:  # a projector's first screen shows the picture; the settings are one click away
            settings = [
                pn.Card(
                    *settings,
                    title="The scenario and its settings",
                    collapsed=True,
                    sizing_mode="stretch_width",
                    margin=(5, 10),
                )
            ]
        return pn.Column(
            *settings,
            pn.pane.Markdown(self.state.scenarios.param.note, margin=(0, 10)),
            pn.pane.Bokeh(self._ratio_fig, margin=5, sizing_mode="stretch_width"),
            bias,
            pn.pane.Bokeh(self._sigma_fig, margin=5, sizing_mode="stretch_width"),
            self._periods,
            self._tuning,
            map_intro,
            self._map_controls(),
            self._map,
            sizing_mode="stretch_width",
        )
