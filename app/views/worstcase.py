"""Worst-case view: each filter's largest RMSE ratio over an unknown σ in [σ min, σ max], per α.

The headline comparison of the baselines (:func:`isl_core.worst_case`): for each α (rows) and filter (columns),
``W = max_{σ, i} š_i/s_i`` over a log-spaced σ grid, simulated with its 95 % batch-means interval, the theory's
worst case beside it (Lyapunov / statistical linearization, :ref:`linearization`; none for the adaptive filter) and ν of
the ISL filters from ``recommend_nu`` over the same σ grid. The dot chart shows the same numbers against α.
The computation runs off the event loop with a progress bar and a cancel button.
"""

from __future__ import annotations

import html
import math

import numpy as np
import panel as pn
import param
from bokeh.core.properties import value
from bokeh.models import ColumnDataSource, FixedTicker, Legend, LegendItem, Range1d, Span, Whisker
from bokeh.plotting import figure
from panel.viewable import Viewer

from isl_core import WORST_CASE_FILTERS, WORST_CASE_LABELS, WorstCaseTable

from ..state import AppState
from .fields import field, list_box
from .filters_panel import number
from .style import FILTER_COLORS, FILTER_MARKERS, TEXT_FONT, job_buttons, px, ratio_axis, styled, text_scale

__all__ = ["WorstCaseView", "worst_case_html"]

_CSS = """
table.isl-worst { border-collapse: collapse; font-size: var(--isl-table-font, 14px); margin: 4px 0 8px 0; }
table.isl-worst th, table.isl-worst td { padding: 4px 8px; text-align: right; border-bottom: 1px solid #ddd; }
table.isl-worst th { font-weight: 600; vertical-align: bottom; }
table.isl-worst td:first-child, table.isl-worst th:first-child { text-align: left; }
table.isl-worst .ci, table.isl-worst .theory { display: block; font-size: var(--isl-tag-font, 12px); color: #555; }
table.isl-worst .theory { font-style: italic; }
table.isl-worst .best { font-weight: 700; }
"""


def _cell(rec: dict, best: bool) -> str:
    if rec["filter"] == "isl_a31" and not math.isfinite(rec["nu"]):
        return "<td><span>—</span><span class='theory'>α not in table A.31</span></td>"
    if not math.isfinite(rec["worst"]):
        sim = "<span>diverged</span>"
    else:
        cls = " class='best'" if best else ""
        sim = (
            f"<span{cls}>{rec['worst']:.3g}</span>"
            f"<span class='ci'>[{rec['worst_low']:.3g}, {rec['worst_high']:.3g}] at σ = {rec['worst_sigma']:.3g}"
            f", X{rec['worst_i']}</span>"
        )
    th = "no theory" if math.isnan(rec["theory_worst"]) else f"theory {rec['theory_worst']:.3g}"
    extra = f", ν = {rec['nu']:.3g}" if math.isfinite(rec["nu"]) else ""
    extra += f", σ̄ = {rec['sigma_design']:.3g}" if math.isfinite(rec["sigma_design"]) else ""
    return f"<td>{sim}<span class='theory'>{th}{extra}</span></td>"


def worst_case_html(table: WorstCaseTable | None) -> str:
    """Rows α, columns filters: simulated worst case [95 % interval], where it sits, theory, ν / σ̄."""
    if table is None:
        return "<p>No table yet: press <b>Compute</b>.</p>"
    recs = table.records()
    nf = len(table.names)
    head = "".join(f"<th>{html.escape(WORST_CASE_LABELS[n])}<span class='ci'>measured</span></th>" for n in table.names)
    rows = []
    for a, alpha in enumerate(table.alphas):
        part = recs[a * nf : (a + 1) * nf]
        worst = [r["worst"] if math.isfinite(r["worst"]) else math.inf for r in part]
        best = int(np.argmin(worst[1:])) + 1 if nf > 1 else 0  # the oracle (column 0) does not compete
        cells = "".join(_cell(r, f == best) for f, r in enumerate(part))
        rows.append(f"<tr><td>α = {alpha:.3g}<span class='ci'>β = {part[0]['beta']:.3g}</span></td>{cells}</tr>")
    return f"<table class='isl-worst'><tr><th>α</th>{head}</tr>{''.join(rows)}</table>"


class WorstCaseView(Viewer):
    """Inputs, compute/cancel/progress, the table and the dot chart of the worst-case comparison."""

    state = param.ClassSelector(class_=AppState)

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._sources = {
            n: ColumnDataSource({"x": [], "y": [], "lower": [], "upper": []}, name=f"worst-{n}")
            for n in WORST_CASE_FILTERS
        }
        self._figure = self._chart()
        self._table = pn.pane.HTML(worst_case_html(self.state.worstcase.table), stylesheets=[_CSS], margin=(0, 10))
        self.state.worstcase.param.watch(self._update, ["table"])
        self._update()

    def _chart(self) -> figure:
        scale = text_scale(self.state)
        fig = styled(
            figure(
                x_axis_type="log",
                y_axis_type="log",
                height=420,
                sizing_mode="stretch_width",
                y_range=Range1d(0.9, 2.0),  # set from each table's intervals (whiskers are not data)
                title="Worst-case RMSE ratio over the σ range (simulated, 95 % intervals)",
                tools="pan,wheel_zoom,box_zoom,reset,save",
            ),
            scale,
        )
        fig.xaxis.axis_label = "α"
        fig.yaxis.axis_label = "max over σ and i of RMSEᵢ / sᵢ"
        ratio_axis(fig, scale)
        fig.add_layout(Span(location=1.0, dimension="width", line_color="#888", line_width=1))
        items = []
        for name, src in self._sources.items():
            color = FILTER_COLORS[name]
            dots = fig.scatter("x", "y", source=src, size=10, color=color, marker=FILTER_MARKERS.get(name, "circle"))
            fig.add_layout(
                Whisker(
                    source=src,
                    base="x",
                    lower="lower",
                    upper="upper",
                    dimension="height",
                    line_color=color,
                    line_width=1.5,
                )
            )
            items.append(LegendItem(label=value(WORST_CASE_LABELS[name]), renderers=[dots]))
        fig.add_layout(
            Legend(items=items, location="top_left", label_text_font_size=f"{11 * scale:.3g}pt", click_policy="hide"),
            "right",
        )
        return fig

    def _update(self, *events) -> None:
        t = self.state.worstcase.table
        self._table.object = worst_case_html(t)
        with pn.io.hold():
            for name, src in self._sources.items():
                if t is None or name not in t.names:
                    src.data = {"x": [], "y": [], "lower": [], "upper": []}
                    continue
                f = t.names.index(name)
                shift = 1.06 ** (f - (len(t.names) - 1) / 2)  # side by side on the log axis
                y, lo, hi = t.worst[:, f], t.worst_low[:, f], t.worst_high[:, f]
                ok = np.isfinite(y) & (y > 0)
                src.data = {"x": t.alphas[ok] * shift, "y": y[ok], "lower": np.maximum(lo[ok], 1e-3), "upper": hi[ok]}
            # the chart shows once there is a table: an empty log-log chart has no range to show. (The figure's
            # own flag: toggling the Panel pane's makes it copy the figure's stylesheets back and fail a type check.)
            self._figure.visible = t is not None
            if t is not None:  # ticks at the table's α only (the dots beside each are its filters), every whisker in
                self._figure.xaxis.ticker = FixedTicker(ticks=[float(a) for a in t.alphas])
                lows, highs = np.asarray(t.worst_low, float), np.asarray(t.worst_high, float)
                ok = np.isfinite(lows) & np.isfinite(highs) & (highs > 0)
                if np.any(ok):
                    lo, hi = max(float(np.min(lows[ok])), 1e-3), float(np.max(highs[ok]))
                    self._figure.y_range.update(start=min(lo, 1.0) / 1.08, end=hi * 1.08)

    def _controls(self) -> pn.Column:
        s = self.state
        p = s.worstcase.param
        lo = field(s, "sigma_min", number(s, "sigma_min", width=px(self.state, 110)))
        hi = field(s, "sigma_max", number(s, "sigma_max", width=px(self.state, 110)))
        alphas = list_box(s, "wc_alphas", pn.widgets.TextInput(label="α values (comma separated)", width=px(s, 220)))
        n = field(s, "wc_n_sigma", number(s, "wc_n_sigma", width=px(self.state, 110)))
        horizon = field(s, "wc_horizon", number(s, "wc_horizon", step=50.0, width=px(self.state, 190)))
        run, cancel, progress = job_buttons(
            p.busy, p.progress, "Compute", s.worstcase.compute, s.worstcase.cancel, scale=text_scale(s)
        )
        note = pn.pane.Markdown(p.note, margin=(0, 10))
        return pn.Column(
            pn.FlexBox(
                lo,
                hi,
                n,
                field(s, "wc_alphas", alphas),
                horizon,
                run,
                cancel,
                progress,
                flex_wrap="wrap",
                sizing_mode="stretch_width",
            ),
            note,  # wraps on a narrow screen (1280 × 720)
            sizing_mode="stretch_width",
        )

    def __panel__(self):
        intro = pn.pane.Markdown(
            "If σ is only known to lie in [σ min, σ max], what matters is each filter's **worst** RMSE ratio over "
            "that range: max over σ (log-spaced grid) and coordinates i of RMSE<sub>i</sub>/s<sub>i</sub>. All "
            "filters run on the same noise. Paper A's ISL filter appears twice: at the **minimax ν** this project "
            "computes for the same σ grid (from the theory) and at the **ν of paper A's table (A.31)**, as "
            "published (for the α that table lists, m = 3, w = 3). The Kalman–Bucy oracle knows σ (≈ 1, a check "
            "of the horizon). **Bold**: the best filter that does not know σ.",
            margin=(0, 10),
            styles={"font-size": TEXT_FONT},
        )
        return pn.Column(
            intro,
            self._controls(),
            self._table,
            pn.pane.Bokeh(self._figure, margin=5, sizing_mode="stretch_width"),
            sizing_mode="stretch_width",
        )
