"""Numbers view: the run's RMSE figures beside the theory, each labelled *measured* or *theory*.

Per coordinate i: the optimal RMSE s_i = √Δ_ii (theory, A.29), the Kalman–Bucy filter's measured ratio
ŝ_i/s_i (A.30; ≈ 1 up to sampling error on long runs), the ISL filter's measured ratio š_i/s_i and its
statistical-linearization prediction (theory, B.48, :ref:`linearization`), and the measured share of steps at which X_i
lies in the tube X̂_i ± 3 s_i (theory: 99.73 % for a Gaussian error of standard deviation s_i). Extra filters
(:mod:`app.extras`), when drawn, get a table of their own: one row per filter, its measured ratio per coordinate with
the theory beside it (Lyapunov for the fixed-gain Kalman–Bucy filters, :ref:`linearization` for the model-aware ISL
filter, none for the adaptive one, whose time-averaged σ̂ is shown instead). Below: r_min (A.24), T, h, N.
"""

from __future__ import annotations

import html

import numpy as np
import panel as pn
import param
from panel.viewable import Viewer

from isl_core.runview import TUBE_THEORY

from ..pipeline import COORDINATES
from ..state import AppState
from ..text import num, per_r_min_html
from .style import EXTRA_COLORS, NOTE_FONT, SUBSCRIPT, text_scale

__all__ = ["TABLE_CSS", "THEORY_OFF", "NumbersView", "numbers_html", "theory_cell"]

TABLE_CSS = """
table.isl-numbers { border-collapse: collapse; font-size: var(--isl-table-font, 15px); margin: 4px 0 8px 0; }
table.isl-numbers th, table.isl-numbers td { padding: 4px 8px; text-align: right; border-bottom: 1px solid #ddd; }
table.isl-numbers th { font-weight: 600; vertical-align: bottom; }
table.isl-numbers td:first-child, table.isl-numbers th:first-child { text-align: left; }
table.isl-numbers .tag { display: block; font-weight: normal; font-size: var(--isl-tag-font, 12px); color: #595959; }
table.isl-numbers .theory { color: #555; font-style: italic; }
table.isl-numbers.run td { text-align: left; }
table.isl-numbers.ratios td { white-space: nowrap; }
table.isl-numbers.ratios td .tag, table.isl-numbers.ratios td:first-child { white-space: normal; }
p.isl-note { font-size: var(--isl-note-font, 13px); margin: 0 0 8px 0; }
"""


THEORY_OFF = 2.0  #: a measured ratio this many times the theory's (or below 1/this) is far beyond one run's scatter


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def _theory_aside(measured: float, theory: float | None) -> str:
    """The theory beside a measured ratio of the extra filters' table, in brackets (by :func:`theory_cell`'s rule)."""
    if theory is None or not np.isfinite(theory):
        return ""
    if measured > THEORY_OFF * theory or measured < theory / THEORY_OFF:
        return " <span class='theory'>(theory not valid here)</span>"
    return f" <span class='theory'>({_fmt(theory)})</span>"


def theory_cell(measured: float, theory: float) -> str:
    """The theory's ratio, or why it is not shown: none where the linearized filter is unstable, and not where the
    run measured :data:`THEORY_OFF` times more (or less) — statistical linearization assumes the innovation stays
    Gaussian, which a filter that has lost lock (small ν) violates; the theory then under-predicts, by tens at
    ν = 0.001, and is not a number to read."""
    if not np.isfinite(theory):
        return "<td class='theory'>—<span class='tag'>unstable in theory</span></td>"
    if measured > THEORY_OFF * theory or measured < theory / THEORY_OFF:  # why: once, below the table (LOST_LOCK)
        return f"<td class='theory'>not valid<span class='tag'>measured is {measured / theory:.3g}× it †</span></td>"
    return f"<td class='theory'>{_fmt(theory)}</td>"


#: below the ratios where a theory cell says "not valid" (said once, so that the table keeps its width)
LOST_LOCK = (
    "<p class='isl-note'>† The filter has lost lock: statistical linearization assumes the innovation stays "
    "Gaussian, which does not hold here (ν sweep tab).</p>"
)


def _ratio(x: float) -> str:
    """A measured ratio: three decimals, or four significant digits once it is 1000 or more (a filter that lost lock
    reads 658310, not 658309.575: the table keeps its width)."""
    return f"{x:.3f}" if abs(x) < 1000 else num(x, 4)


def extras_html(run, extra_prediction: dict | None) -> str:
    """Table of the run's extra filters (tracks after KBF and ISL): measured ratio (theory) per coordinate."""
    tracks = run.tracks[2:]
    if not tracks:
        return ""
    pred = extra_prediction or {}
    head = "".join(
        f"<th>š{str(i + 1).translate(SUBSCRIPT)}/s{str(i + 1).translate(SUBSCRIPT)}"
        "<span class='tag'>measured (theory)</span></th>"
        for i in range(run.model.m)
    )
    rows = []
    for tr in tracks:
        th = pred.get(tr.name)
        cells = "".join(
            f"<td>{tr.ratio[i]:.3f}{_theory_aside(tr.ratio[i], None if th is None else th[i])}</td>"
            for i in range(run.model.m)
        )
        note = "" if tr.sigma_hat_mean is None else f"<span class='tag'>mean σ̂ = {tr.sigma_hat_mean:.4g}</span>"
        color = EXTRA_COLORS.get(tr.name, "#000")
        key = f"<span style='color:{color}'>&#9632;</span>"
        rows.append(f"<tr><td>{key} {html.escape(tr.label)}{note}</td>{cells}</tr>")
    return f"<table class='isl-numbers extras'><tr><th>other filters</th>{head}</tr>{''.join(rows)}</table>"


def numbers_html(run, prediction, compute_seconds: float, extra_prediction: dict | None = None) -> str:
    """The tables (per-coordinate ratios; the extra filters' ratios, if any; run figures) as HTML."""
    if run is None:
        return "<p><i>The numbers appear with the first run.</i></p>"
    head = (
        "<tr><th>coordinate</th><th>s<sub>i</sub><span class='tag'>theory</span></th>"
        "<th>ŝ<sub>i</sub>/s<sub>i</sub> KBF<span class='tag'>measured</span></th>"
        "<th>š<sub>i</sub>/s<sub>i</sub> ISL<span class='tag'>measured</span></th>"
        "<th>š<sub>i</sub>/s<sub>i</sub> ISL<span class='tag'>theory</span></th>"
        f"<th>X<sub>i</sub> in tube<span class='tag'>measured (theory {100 * TUBE_THEORY:.1f} %)</span></th></tr>"
    )
    rows = []
    for i in range(run.model.m):
        k = str(i + 1).translate(SUBSCRIPT)
        rows.append(
            f"<tr><td>X{k} {html.escape(COORDINATES[i])}</td><td class='theory'>{_fmt(run.s[i])}</td>"
            f"<td>{_ratio(run.ratio_hat[i])}</td><td>{_ratio(run.ratio_check[i])}</td>"
            f"{theory_cell(run.ratio_check[i], prediction[i])}<td>{100 * run.tracks[0].inside[i]:.1f} %</td></tr>"
        )
    longer = (
        ""
        if run.stretch == 1.0
        else (
            f"<span class='tag'>lengthened ×{run.stretch:.3g}: the ISL filter at this ν settles that much slower than "
            "the optimal one (B.46)</span>"
        )
    )
    facts = (
        f"<tr><td>r<sub>min</sub> (settling rate, theory)</td><td>{_fmt(run.r_min)}</td></tr>"
        f"<tr><td>T (simulated time)</td><td>{_fmt(run.T)} = {per_r_min_html(run.T * run.r_min, 3)}{longer}</td></tr>"
        "<tr><td>averaging window</td><td>t ∈ [0, T], no burn-in: every filter starts at X(0) − e₀, "
        "e₀ ~ N(0, Δ)</td></tr>"
        f"<tr><td>h (Euler step)</td><td>{run.h:.3g}</td></tr>"
        f"<tr><td>N (steps)</td><td>{run.N:,}</td></tr>"
        f"<tr><td>compute time (server)</td><td>{1000 * compute_seconds:.0f} ms</td></tr>"
    )
    note = LOST_LOCK if any("†" in row for row in rows) else ""
    return (
        f"<table class='isl-numbers ratios'>{head}{''.join(rows)}</table>{note}"
        f"{extras_html(run, extra_prediction)}<table class='isl-numbers run'>{facts}</table>"
    )


class NumbersView(Viewer):
    """The numbers table of the current run."""

    state = param.ClassSelector(class_=AppState)

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self._pane = pn.pane.HTML(self._html(), stylesheets=[TABLE_CSS], margin=(0, 10))
        self.state.param.watch(self._update, ["run", "prediction", "extra_prediction"])

    def _html(self) -> str:
        s = self.state
        return numbers_html(s.run, s.prediction, s.compute_seconds, s.extra_prediction)

    def _update(self, *events) -> None:
        self._pane.object = self._html()

    def __panel__(self):
        return pn.Column(
            pn.pane.Markdown("### RMSE: measured on this run vs theory", margin=(0, 10)),
            self._pane,
            pn.pane.Markdown(
                "Ratios are RMSE / s<sub>i</sub>: 1 is optimal. Measured ratios on one short run scatter by "
                "±10 % or more; a longer horizon narrows them.",
                margin=(0, 10),
                styles={"font-size": NOTE_FONT},
            ),
            width=round(430 * text_scale(self.state)),
        )
