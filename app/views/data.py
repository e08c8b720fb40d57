"""The "Your data" tab: a recorded series — a shipped data set or a CSV file of one's own — the model fitted to it, and
every filter over it, judged on the held-out tail (:class:`app.state.DataRoom`, :ref:`data`).

The inputs (the data set, the file with its time and value columns, the held-out share) and the fit's long job
(button, cancel, progress); the fitted parameters with their standard errors and the m chosen (AIC/BIC of every m);
the readings with every filter's estimate of X₁ and its ±3 band where the filter states a variance (one plot, the
held-out tail marked); the diagnostics; and the downloads. The plot is built once and updated in place.
"""

from __future__ import annotations

import html
import math

import numpy as np
import panel as pn
import param
from bokeh.core.properties import value
from bokeh.models import ColumnDataSource, Legend, LegendItem, Span
from bokeh.plotting import figure
from panel.viewable import Viewer

from isl_core.series import SERIES_FILTERS
from isl_core.series.sources import MAX_ROWS

from ..colors import KBF
from ..state import AppState, declaration
from ..state.data_job import MAX_UPLOAD
from .fields import REFUSAL_CSS, field
from .file_picker import FilePicker
from .filters_panel import bind
from .filters_panel import number as number_box
from .scenario_tables import SCENARIO_COLORS
from .style import SCENARIO_DASHES, TEXT_FONT, job_buttons, px, styled, text_scale

__all__ = ["COLORS", "DASHES", "DataView", "diagnostics_html", "fit_html"]

#: each filter's colour and line pattern, as in the scenario plots (the Kalman filter at the fitted σ_r: the green
#: of the Kalman–Bucy filter that knows σ)
COLORS = {**{n: SCENARIO_COLORS.get(n, KBF) for n in SERIES_FILTERS}, "kalman": KBF}
DASHES = {**{n: SCENARIO_DASHES.get(n, "solid") for n in SERIES_FILTERS}, "kalman": "solid"}
SOURCE_LABELS = {
    "nile": "Nile: yearly flow 1871–1970",
    "co2": "CO₂ at Mauna Loa: weekly, with gaps",
    "long": "long: 200 000 synthetic readings",
    "upload": "your CSV file",
}
_CSS = """
table.isl-data { border-collapse: collapse; font-size: var(--isl-table-font, 14px); margin: 4px 0 8px 0; }
table.isl-data caption { text-align: left; font-weight: 600; padding: 4px 0; }
table.isl-data th, table.isl-data td { padding: 4px 8px; text-align: right; border-bottom: 1px solid #ddd; }
table.isl-data th:first-child, table.isl-data td:first-child { text-align: left; }
table.isl-data .best { font-weight: 700; }
table.isl-data .ci { display: block; font-size: var(--isl-tag-font, 12px); color: #555; }
div.isl-data-pair { display: flex; flex-wrap: wrap; gap: 8px 40px; align-items: flex-start; }
"""


def _num(x, digits: int = 4) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{x:.{digits}g}"


def _pm(x, se) -> str:
    return _num(x, 6) + ("" if se is None or not math.isfinite(se) else f" ± {_num(se, 3)}")


def fit_html(summary: dict | None) -> str:
    """The fitted parameters with their standard errors, and AIC/BIC of every m with the one chosen in bold."""
    if summary is None:
        return ""
    f = summary["fit"]
    alpha = _pm(f["alpha"], f["alpha_se"]) + (" (given)" if f["alpha_fixed"] else "")
    rows = [
        ("m (order)", str(f["m"])),
        ("α", alpha),
        ("β", _pm(f["beta"], f["beta_se"])),
        ("σ_r (a reading's noise sd)", _pm(f["sigma_r"], f["sigma_r_se"])),
        ("σ = σ_r·√Δ̄ (the model's)", _pm(f["sigma"], f["sigma_se"])),
        ("log L", f"{f['loglik']:.6g} on {f['n']} readings"),
        ("ISL filters' ν", _num(summary["nu"], 6)),
    ]
    body = "".join(f"<tr><td>{html.escape(k)}</td><td>{html.escape(v)}</td></tr>" for k, v in rows)
    params = (
        "<table class='isl-data'><caption>Fitted by maximum likelihood (± standard error)</caption>"
        f"<tr><th scope='col'>parameter</th><th scope='col'>value</th></tr>{body}</table>"
    )
    if not summary["orders"]:
        return f"<div class='isl-data-pair'>{params}</div>"
    orders = "".join(
        f"<tr{' class=best' if o['m'] == f['m'] else ''}><td>{o['m']}</td><td>{o['loglik']:.2f}</td>"
        f"<td>{o['aic']:.2f}</td><td>{o['bic']:.2f}</td></tr>"
        for o in summary["orders"]
    )
    return (
        f"<div class='isl-data-pair'>{params}"
        "<table class='isl-data'><caption>The order m: least BIC chosen (bold)</caption>"
        "<tr><th scope='col'>m</th><th scope='col'>log L</th><th scope='col'>AIC</th><th scope='col'>BIC</th></tr>"
        f"{orders}</table></div>"
    )


def diagnostics_html(summary: dict | None) -> str:
    """Each filter's diagnostics on the held-out tail, with what each column means."""
    if summary is None:
        return ""
    diags = summary["diagnostics"]
    n = diags[0]["n"] if diags else 0
    lo, hi = diags[0]["nis_interval"] if diags else (math.nan, math.nan)
    rows = "".join(
        f"<tr><td>{html.escape(d['label'])}</td><td>{_num(d['rmse'])}</td><td>{_num(d['nis'], 3)}</td>"
        f"<td>{_num(d['ljung_box_p'], 2)}</td><td>{_num(d['predictive_loglik'], 5)}</td></tr>"
        for d in diags
    )
    return (
        f"<table class='isl-data'><caption>Computed on the held-out tail: {n} readings the fit never saw</caption>"
        "<tr><th scope='col'>filter</th><th scope='col'>prediction RMSE</th>"
        f"<th scope='col'>NIS<span class='ci'>95 % range {_num(lo, 3)}–{_num(hi, 3)}</span></th>"
        "<th scope='col'>Ljung–Box p</th><th scope='col'>predictive log L</th></tr>"
        f"{rows}</table>"
    )


DIAGNOSTICS_NOTE = (
    "**Prediction RMSE**: the root mean square of the one-step prediction errors (the reading's own noise included: "
    "smaller is better). **NIS**: the mean of each squared error divided by the variance the filter states for it — "
    "near 1, inside the range, for a filter whose stated variance is right; above, overconfident. **Ljung–Box p**: "
    "a small p (below 0.01) says the errors are correlated — the filter leaves part of the signal unpredicted. "
    "**Predictive log L**: the log-likelihood of the held-out readings under the filter's stated Gaussian (larger is "
    "better). The ISL filters state no variance: no NIS and no predictive log L (—)."
)


class DataView(Viewer):
    """Inputs, the fit's job, the fit and order tables, the plot, the diagnostics and the downloads."""

    state = param.ClassSelector(class_=AppState)

    def __init__(self, **params) -> None:
        super().__init__(**params)
        room = self.state.data
        self._readings = ColumnDataSource({"t": [], "z": []}, name="data-readings")
        self._sources = {
            n: ColumnDataSource({"t": [], "y": [], "low": [], "high": []}, name=f"data-{n}") for n in SERIES_FILTERS
        }
        self._items: dict[str, LegendItem] = {}
        self._split = Span(location=0.0, dimension="height", line_color="#555", line_dash="dashed", visible=False)
        self._figure = self._plot()
        self._fit = pn.pane.HTML("", stylesheets=[_CSS], margin=(0, 10))
        self._diagnostics = pn.pane.HTML("", stylesheets=[_CSS], margin=(0, 10))
        self._refusal = pn.pane.HTML("", visible=False, stylesheets=[REFUSAL_CSS], margin=(0, 10, 6, 10))
        room.param.watch(self._update, ["result"])
        room.param.watch(self._show_refusal, ["upload_note"])
        room.want()
        self._update()
        self._show_refusal()

    def _plot(self) -> figure:
        scale = text_scale(self.state)
        fig = styled(
            figure(
                height=460,
                sizing_mode="stretch_width",
                title="The readings and every filter's estimate of X₁ (±3 stated sd where it states one)",
                tools="pan,xwheel_zoom,box_zoom,reset,save",
            ),
            scale,
        )
        fig.xaxis.axis_label = "time"
        fig.yaxis.axis_label = "reading, X₁"
        fig.add_layout(self._split)
        dots = fig.scatter("t", "z", source=self._readings, size=4, color="#000000", alpha=0.6)
        items = [LegendItem(label=value("readings"), renderers=[dots])]
        for name, src in self._sources.items():
            color = COLORS[name]
            band = fig.varea("t", "low", "high", source=src, color=color, fill_alpha=0.10)
            line = fig.line("t", "y", source=src, color=color, line_width=2, line_dash=DASHES[name])
            self._items[name] = LegendItem(label=value(name), renderers=[line, band])
            items.append(self._items[name])
        fig.add_layout(
            Legend(
                items=items,
                orientation="horizontal",
                ncols=2,
                click_policy="hide",
                label_text_font_size=f"{10 * scale:.3g}pt",
            ),
            "below",
        )
        return fig

    def _update(self, *events) -> None:
        res = self.state.data.result
        self._fit.object = fit_html(None if res is None else res.summary)
        self._diagnostics.object = diagnostics_html(None if res is None else res.summary)
        with pn.io.hold():
            if res is None:
                self._readings.data = {"t": [], "z": []}
                for src in self._sources.values():
                    src.data = {"t": [], "y": [], "low": [], "high": []}
                self._split.visible = False
                return
            self._readings.data = {"t": res.t, "z": res.z}
            for line in res.lines:
                none = np.full(len(line.t), np.nan)
                low = line.low if line.low is not None else none
                high = line.high if line.high is not None else none
                self._sources[line.name].data = {"t": line.t, "y": line.y, "low": low, "high": high}
                label = line.label + ("" if line.low is not None else " (no band)")
                if self._items[line.name].label != value(label):
                    self._items[line.name].label = value(label)
            self._split.update(location=res.t_split, visible=True)

    def _show_refusal(self, *events) -> None:
        text = self.state.data.upload_note
        body = f"<div class='isl-refusal' role='alert'>{html.escape(text)}</div>" if text else ""
        if self._refusal.object != body:
            self._refusal.param.update(object=body, visible=bool(text))

    def _file_input(self) -> pn.Column:
        room = self.state.data
        mb = MAX_UPLOAD // 1_000_000
        upload = FilePicker(
            on_file=room.upload,
            on_too_large=room.too_large,
            label=f"your CSV file (at most {mb} MB)",
            hint=f"UTF-8 text, at most {mb} MB and {MAX_ROWS:,} rows",
            accept=".csv,.txt,text/csv,text/plain",
            max_size=MAX_UPLOAD,
            width=px(self.state, 280),
            margin=(5, 10, 0, 10),
        )
        return pn.Column(upload, self._refusal, margin=0, width=px(self.state, 300))

    def _columns(self) -> pn.Row:
        room = self.state.data
        time = pn.widgets.Select(label="time column", options=[], width=px(self.state, 150), visible=False)
        val = pn.widgets.Select(label="value column", options=[], width=px(self.state, 150), visible=False)

        def show(*events) -> None:
            cols = list(room.columns)
            shown = len(cols) > 1 and room.source == "upload"
            for box, chosen in ((time, room.time_column), (val, room.value_column)):
                box.param.update(options=cols, value=chosen if chosen in cols else None, visible=shown)

        def chosen(event) -> None:
            if time.value and val.value:
                room.choose_columns(time.value, val.value)

        room.param.watch(show, ["columns", "time_column", "value_column", "source"])
        time.param.watch(chosen, "value")
        val.param.watch(chosen, "value")
        show()
        return pn.Row(time, val, margin=0)

    def _controls(self) -> pn.Column:
        s = self.state
        p = s.data.param
        decl = declaration("data_set")
        source = field(
            s,
            "data_set",
            bind(
                s,
                "data_set",
                pn.widgets.Select(
                    label=decl.label,
                    options={SOURCE_LABELS[v]: v for v in decl.objects},
                    width=px(s, 300),
                    description=decl.doc,
                ),
            ),
        )
        holdout = field(s, "data_holdout", number_box(s, "data_holdout", step=0.05, width=px(s, 150)))
        order = field(s, "data_m", number_box(s, "data_m", width=px(s, 170)))
        run, cancel, progress = job_buttons(p.busy, p.progress, "Fit", s.data.fit, s.data.cancel, scale=text_scale(s))
        downloads = [
            pn.widgets.FileDownload(
                callback=fn,
                filename=name,
                label=label,
                color="success",
                variant="outline",
                width=px(s, 190),
                margin=(24, 10, 0, 10),
            )
            for fn, name, label in (
                (s.data.estimates_file, "isl_data_estimates.csv", "Estimates (CSV)"),
                (s.data.fit_file, "isl_data_fit.json", "Fit and diagnostics (JSON)"),
            )
        ]
        row = dict(flex_wrap="wrap", sizing_mode="stretch_width")
        return pn.Column(
            pn.FlexBox(source, self._file_input(), self._columns(), **row),
            pn.FlexBox(holdout, order, run, cancel, progress, *downloads, **row),
            sizing_mode="stretch_width",
        )

    def __panel__(self):
        intro = pn.pane.Markdown(
            "A **recorded series** instead of a simulated one: a data set shipped with the packages, or a CSV file of "
            f"your own — UTF-8 text, at most **{MAX_UPLOAD // 1_000_000} MB** and **{MAX_ROWS:,} rows**, a column of "
            "times (strictly increasing, regular or not; dates allowed) and one of readings (an empty cell: no "
            "reading); `#` lines are comments. The file stays in this page's memory only, and is dropped when you "
            "leave. The model's α, β and the reading noise σ_r are fitted by **maximum likelihood** on the first part "
            "of the series (m = 1 … 6, the order of least BIC, unless you give m), every filter runs over the whole "
            "series with them, "
            "and each is judged on the **held-out tail** by how well it predicted readings the fit never saw — there "
            "is no truth to compare with.",
            margin=(0, 10),
            styles={"font-size": TEXT_FONT},
        )
        settings: list = [intro, self._controls()]
        if self.state.present:  # the picture first on a projector; the settings one click away
            settings = [
                pn.Card(*settings, title="The series and its settings", collapsed=True, sizing_mode="stretch_width")
            ]
        return pn.Column(
            *settings,
            pn.pane.Markdown(self.state.data.param.note, margin=(0, 10)),
            self._fit,
            pn.pane.Bokeh(self._figure, margin=5, sizing_mode="stretch_width"),
            self._diagnostics,
            pn.pane.Markdown(DIAGNOSTICS_NOTE, margin=(0, 10), styles={"font-size": TEXT_FONT}),
            sizing_mode="stretch_width",
        )
