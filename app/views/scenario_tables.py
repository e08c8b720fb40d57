"""The Scenario tab's two tables: every filter's period statistic, and the who-wins map (HTML).

:func:`periods_html` is the picture's summary: per filter its tuning, its RMSE ratio to the clairvoyant filter over
each fixed period of the scenario (the first 1/r_min and 2/r_min after a change of σ, the settled rest) at its worst
coordinate with the 95 % interval over the runs — on which the clairvoyant row reads 1 — the worst run and the runs
above 2×, and its cost in nanoseconds a step. :func:`map_html`
colours each cell of the who-wins map by its winner, in black or white text, whichever reads at 4.5 : 1 or more on
it; a tie (the winner's margin over the runner-up not told apart by the runs) is a light shade of the winner's
colour with a dashed border. A key under the map names its short labels.
"""

from __future__ import annotations

import html
import math

import numpy as np

from isl_core.scenario.map import AXIS_LABELS

from ..colors import EXTRA_COLORS, ISL, KBF, text_on, tint
from ..scenario_picture import LOOP
from ..text import R_MIN, R_MIN_HTML

__all__ = ["SCENARIO_COLORS", "SHORT", "TABLE_CSS", "map_html", "periods_html"]

#: every filter of a picture or a map; the clairvoyant reference in grey, the two filters paper A compares as
#: everywhere, the ISL filter at the tuned ν a lighter blue
SCENARIO_COLORS = {
    "clairvoyant": "#6b6b6b",
    "kbf": KBF,
    "isl": ISL,
    "isl_tuned": "#7b9be0",
    "vb": "#7b3294",
    "kbf_robust": "#d6604d",
    "imm": "#c51b7d",  # magenta: the green is the constant-σ Kalman–Bucy filter's
    **{k: v for k, v in EXTRA_COLORS.items() if k != "kbf"},
}
#: the map's short names (its key spells them out)
SHORT = {
    "clairvoyant": "clairvoyant",
    "kbf": "KBF σ(0)",
    "isl": "ISL",
    "isl_tuned": "ISL tuned",
    "kbf_adaptive": "adaptive",
    "vb": "VB",
    "kbf_robust": "robust",
    "isl_model": "ISL model-aware",
    "imm": "IMM",
}
REFERENCES = ("clairvoyant", "kbf")  #: filters that know σ: they do not compete
TABLE_CSS = """
table.isl-scn { border-collapse: collapse; font-size: var(--isl-table-font, 14px); margin: 4px 0 8px 0; }
table.isl-scn th, table.isl-scn td { padding: 4px 8px; text-align: right; border-bottom: 1px solid #ddd; }
table.isl-scn td:first-child, table.isl-scn th:first-child { text-align: left; }
table.isl-scn .ci { display: block; font-size: var(--isl-tag-font, 12px); color: #555; }
table.isl-scn .best { font-weight: 700; }
table.isl-scn td.cell { text-align: center; }
table.isl-scn td.tie { outline: 2px dashed #444; outline-offset: -3px; }
table.isl-scn td.tuning { text-align: left; font-size: var(--isl-tag-font, 12px); color: #444; }
p.isl-key { font-size: var(--isl-tag-font, 12px); margin: 0 0 8px 0; }
"""


def _swatch(name: str) -> str:
    return f"<span style='color:{SCENARIO_COLORS.get(name, '#000')}' aria-hidden='true'>&#9632;</span> "


def _cell(ratio: float, low: float, high: float, best: bool, coordinate: int, worst: float, above: int) -> str:
    """A period's cell: the worst coordinate's ratio, its interval, that coordinate, the worst run's own ratio and
    how many runs read above 2×."""
    if not math.isfinite(ratio):
        return f"<td>diverged<span class='ci'>on X{coordinate + 1}</span></td>"
    value = f"<span class='best'>{ratio:.3g}</span>" if best else f"{ratio:.3g}"
    runs = f" · {above} run{'s' if above != 1 else ''} > 2×" if above else ""
    return (
        f"<td>{value}<span class='ci'>[{low:.3g}, {high:.3g}]</span>"
        f"<span class='ci'>X{coordinate + 1} · worst run {worst:.3g}{runs}</span></td>"
    )


def _cost_cell(name: str, names, costs) -> str:
    """A filter's cost cell; the loop's own three filters run together and share one cell over their rows."""
    if name in LOOP:
        together = [n for n in names if n in LOOP]
        if name != together[0]:
            return ""
        base = "" if costs is None else f"{costs['loop']:,.0f}<span class='ci'>the {len(together)} together</span>"
        return f"<td rowspan='{len(together)}'>{base}</td>"
    return f"<td>{'' if costs is None or name not in costs else f'{costs[name]:,.0f}'}</td>"


def periods_html(pic, costs: dict[str, float] | None = None) -> str:
    """The picture's filters (rows) by the scenario's periods (columns), their tunings and costs (module docstring);
    bold: the lowest ratio in a period among the filters that do not know σ."""
    if pic is None:
        return ""
    if pic.periods is None:
        return "<p>No period statistic from one run: average 2 runs or more for its interval.</p>"
    pr, run = pic.periods, pic.average.run
    competing = np.array([name not in REFERENCES for name in pr.filters])
    best = np.argmin(np.where(competing[:, None] & np.isfinite(pr.ratio), pr.ratio, np.inf), axis=0)
    head = "".join(
        f"<th>{html.escape(p.label.replace('r_min', R_MIN))}<span class='ci'>ratio [95 %]</span></th>"
        for p in pr.periods
    )
    rows = []
    worst, above = pr.worst_seed, pr.above(2.0)
    for f, (name, label) in enumerate(zip(run.names, run.labels, strict=True)):
        cells = "".join(
            _cell(
                pr.ratio[f, c],
                pr.low[f, c],
                pr.high[f, c],
                competing[f] and best[c] == f,
                int(pr.coordinate[f, c]),
                worst[f, c],
                int(above[f, c]),
            )
            for c in range(len(pr.periods))
        )
        cost = _cost_cell(name, run.names, costs)
        rows.append(
            f"<tr><td>{_swatch(name)}{html.escape(label)}</td><td class='tuning'>"
            f"{html.escape(pic.tuning.get(name, ''))}</td>{cells}{cost}</tr>"
        )
    cost_head = "<th>cost<span class='ci'>ns a step, measured</span></th>"
    return (
        f"<table class='isl-scn'><tr><th>filter</th><th>tuning</th>{head}{cost_head}</tr>{''.join(rows)}</table>"
        f"<p class='isl-key'>Each ratio is the filter's RMSE over the clairvoyant filter's exact standard "
        f"deviation at its worst coordinate (Xi), pooled over the {len(pic.average.seeds)} runs (seeds "
        f"{pic.average.seeds[0]}–{pic.average.seeds[-1]}), with Student's 95 % interval over them: the clairvoyant "
        "row reads 1 up to that interval and the maximum over the coordinates' noise. Under it, the worst run's own "
        "ratio and how many runs read above 2×. Bold: the lowest ratio in a period among the filters that do not "
        f"know σ. Knobs: {html.escape(pic.origin)}.</p>"
    )


def map_html(res) -> str:
    """The who-wins map: a cell per swept value (and per period after the step), coloured by its winner, with the
    margin over the runner-up; a light cell with a dashed border, marked "≈", is a tie; and the key of its names."""
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
            back = tint(SCENARIO_COLORS[name], 0.3) if tie else SCENARIO_COLORS[name]
            ink = text_on(back)
            cells.append(
                f"<td class='cell{' tie' if tie else ''}' style='background:{back};color:{ink}' "
                f"title='{html.escape(res.labels[res.winner[r, c]])}'>{'≈ ' if tie else ''}"
                f"{html.escape(SHORT[name])}<span class='ci' style='color:{ink}'>×{res.margin[r, c]:.2f}"
                "</span></td>"
            )
        rows.append(f"<tr><td>{label}</td>{''.join(cells)}</tr>")
    corner = f"time since the step (1/{R_MIN_HTML}) \\ " if res.kind == "sigma_step" else ""
    key = " · ".join(
        f"{_swatch(n)}<b>{html.escape(SHORT[n])}</b>: {html.escape(lab)}"
        for n, lab in zip(res.filters, res.labels, strict=True)
        if n in SHORT
    )
    return (
        f"<table class='isl-scn'><tr><th>{corner}{html.escape(AXIS_LABELS[res.kind])}</th>{head}</tr>"
        f"{''.join(rows)}</table><p class='isl-key'>{key}</p>"
    )
