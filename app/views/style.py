"""Colours and fonts shared by the plots (sized to stay readable on a projector), and a long job's buttons."""

from __future__ import annotations

import panel as pn
from bokeh.models import BasicTickFormatter, ColumnDataSource, CustomJSTicker, GlyphRenderer, Line, PrintfTickFormatter
from bokeh.plotting import figure

from ..colors import EXTRA_COLORS, ISL, KBF, TRUTH

__all__ = [
    "EXTRA_COLORS",
    "EXTRA_DASHES",
    "FILTER_COLORS",
    "FILTER_MARKERS",
    "ISL",
    "KBF",
    "NOTE_FONT",
    "PRESENTER_SCALE",
    "RATIO_MANTISSAS",
    "SCENARIO_DASHES",
    "SIGMA_COLORS",
    "SIGMA_DASHES",
    "SUBSCRIPT",
    "TEXT_FONT",
    "TRUTH",
    "job_buttons",
    "line",
    "px",
    "ratio_axis",
    "ratio_ticker",
    "styled",
    "text_scale",
]

#: every filter of isl_core.WORST_CASE_FILTERS (the ISL filter at table A.31's ν: a lighter blue)
#: dash pattern of each baseline's line over the trajectories: where two estimates coincide (the adaptive filter on
#: the optimal one, the mismatched one at σ̄ = σ) the one below still shows between the dashes
EXTRA_DASHES = {"kbf_mismatched": "dashed", "kbf_minimax": "dotdash", "kbf_adaptive": [6, 3], "isl_model": [2, 2]}
FILTER_COLORS = {"kbf": KBF, "isl": ISL, "isl_a31": "#7b9be0", **EXTRA_COLORS}
#: each filter's marker where filters are drawn as points (the worst case): the shape tells them apart, not only the hue
FILTER_MARKERS = {
    "kbf": "circle",
    "isl": "square",
    "isl_a31": "square_pin",
    "kbf_mismatched": "triangle",
    "kbf_minimax": "inverted_triangle",
    "kbf_adaptive": "diamond",
    "isl_model": "hex",
}
#: each filter's line pattern in the scenario plots (by the names of :func:`app.scenario_picture.scenario_picture`'s
#: run): no two filters share one, so that a line is told apart without its colour
SCENARIO_DASHES = {
    "clairvoyant": "dashed",
    "kbf": "solid",
    "isl": [10, 3],
    "isl_tuned": [10, 3, 2, 3],
    "vb": "dotted",
    "kbf_robust": "dotdash",
    "imm": [2, 2],
    "kbf_mismatched": [6, 3],
    "kbf_minimax": "dashdot",
    "kbf_adaptive": [14, 4],
    "isl_model": [4, 2, 4, 6],
}
SIGMA_COLORS = ("#d95f02", "#7570b3", "#1b9e77", "#e7298a", "#66a61e")  #: one per σ of the sweep
SIGMA_DASHES = ("dotted", "dashed", "solid", "dashdot", "dotdash")  #: paper A, Fig. 2: σ = 2, 20, 200
SUBSCRIPT = str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉")


TEXT_FONT = "var(--isl-text-font, 14px)"  #: the views' explanatory text (larger in presenter mode: app.page)
NOTE_FONT = "var(--isl-note-font, 13px)"  #: their small print

#: how much larger a plot's text is in presenter mode (the page's text goes from 14 to 19 px there)
PRESENTER_SCALE = 19 / 14


def text_scale(state) -> float:
    """The plots' font scale for ``state``'s page: :data:`PRESENTER_SCALE` in presenter mode, else 1."""
    return PRESENTER_SCALE if state.present else 1.0


def px(state, width: int) -> int:
    """A widget's width in pixels for ``state``'s page: wider in presenter mode, where its text is larger."""
    return round(width * text_scale(state))


def styled(fig: figure, scale: float = 1.0) -> figure:
    """Large fonts (times ``scale``: :data:`PRESENTER_SCALE` for a projector), light grid, no logo."""
    fig.title.text_font_size = f"{14 * scale:.3g}pt"
    fig.title.text_font_style = "bold"
    for axis in (*fig.xaxis, *fig.yaxis):
        axis.axis_label_text_font_size = f"{13 * scale:.3g}pt"
        axis.axis_label_text_font_style = "normal"
        axis.major_label_text_font_size = f"{11 * scale:.3g}pt"
    for axis in fig.yaxis:
        if isinstance(axis.formatter, BasicTickFormatter):  # plain numbers up to 10⁷ (positions drift far)
            axis.formatter = BasicTickFormatter(power_limit_high=7, power_limit_low=-3)
    fig.grid.grid_line_alpha = 0.4
    fig.toolbar.logo = None
    fig.min_border_left = round(70 * scale)
    return fig


def line(
    fig: figure, source: ColumnDataSource, *, x: str = "t", y: str = "y", visible: bool = True, **style
) -> GlyphRenderer:
    """A line of ``source`` in ``fig``, built directly: ``fig.line`` also builds a non-selection and a muted copy of
    the glyph per line (two more models each, 100 of 644 in the m = 6 trajectories), which these plots never use —
    left to the browser ("auto") here."""
    renderer = GlyphRenderer(data_source=source, glyph=Line(x=x, y=y, **style), visible=visible)
    fig.renderers.append(renderer)
    return renderer


#: tick values of a log axis of RMSE ratios, per decade, finest first: a ratio's point is in its first digits
#: (1.06 vs 1.23), which ticks at 1, 10, 100 only (or 5, 10, 15) do not let a reader see
RATIO_MANTISSAS = (
    (1, 1.05, 1.1, 1.2, 1.3, 1.5, 1.7, 2, 2.5, 3, 4, 5, 7),
    (1, 1.1, 1.2, 1.5, 2, 3, 5, 7),
    (1, 1.2, 1.5, 2, 3, 5),
    (1, 2, 5),
    (1, 3),
    (1,),
)


def ratio_axis(fig: figure, scale: float = 1.0) -> None:
    """``fig``'s y axis, a log axis of RMSE ratios, ticked 1, 1.2, 1.5, 2, … (:func:`ratio_ticker`) and labelled
    plainly (1.2, not 1.2e+0), so that 1.06 and 1.23 can be read off (the ν-sweep's and the worst case's charts)."""
    for axis in fig.yaxis:
        axis.ticker = ratio_ticker(fig, min_gap=round(TICK_GAP * scale))
        axis.formatter = PrintfTickFormatter(format="%g")


TICK_GAP = 22  #: least distance in pixels between two tick labels of a ratio axis (an 11 pt label is ≈ 15 px high)


def ratio_ticker(fig: figure | None = None, max_ticks: int = 9, min_gap: int = TICK_GAP) -> CustomJSTicker:
    """Ticks for a log axis of ratios: the finest set of :data:`RATIO_MANTISSAS` that puts at most ``max_ticks``
    ticks in view, at least ``min_gap`` pixels apart on ``fig``'s plot area (1, 1.2, 1.5, 2, 3, 5, … over a ratio
    range of 1–10), computed in the browser as the view changes (at 1.1 and 1.2 two labels overlapped on a short
    range drawn small); a range of many decades falls back to powers of 10 (every k-th one)."""
    code = """
        const lo = Math.min(cb_data.start, cb_data.end), hi = Math.max(cb_data.start, cb_data.end);
        if (!(lo > 0) || !(hi > lo)) return [];
        let px = 0;
        try { px = plot ? plot.inner_height : 0; } catch (e) { px = 0; }  // unset until the plot is laid out
        const apart = (ticks) => { for (let k = 1; k < ticks.length; k++)
            if (px * Math.log(ticks[k] / ticks[k - 1]) / Math.log(hi / lo) < min_gap) return false; return true; };
        const d0 = Math.floor(Math.log10(lo)), d1 = Math.ceil(Math.log10(hi));
        for (const set of sets) {
            const ticks = [];
            for (let d = d0; d <= d1; d++)
                for (const m of set) {
                    const v = Number((m * Math.pow(10, d)).toPrecision(6));
                    if (v >= lo && v <= hi) ticks.push(v);
                }
            if (ticks.length <= max_ticks && ticks.length >= 2 && (!(px > 0) || apart(ticks))) return ticks;
        }
        const step = Math.max(1, Math.ceil((d1 - d0) / max_ticks)), ticks = [];
        for (let d = d0; d <= d1; d += step) { const v = Math.pow(10, d); if (v >= lo && v <= hi) ticks.push(v); }
        return ticks;
    """
    return CustomJSTicker(
        major_code=code,
        args={"sets": [list(m) for m in RATIO_MANTISSAS], "max_ticks": max_ticks, "plot": fig, "min_gap": min_gap},
    )


def job_buttons(
    busy, progress, label: str, start, cancel, *, width: int = 120, below_label: bool = True, scale: float = 1.0
) -> tuple:
    """A long job's start button (disabled while it runs), cancel button and progress bar (both shown while it
    runs), over the state's ``busy`` and ``progress`` parameters; ``below_label``: aligned with labelled inputs;
    ``scale``: the text's (presenter mode's larger text needs wider buttons)."""
    margin = (24, 10, 0, 10) if below_label else (5, 10)
    run = pn.widgets.Button(label=label, color="primary", width=round(width * scale), disabled=busy, margin=margin)
    run.on_click(lambda event: start())
    stop = pn.widgets.Button(label="Cancel", color="danger", width=round(90 * scale), visible=busy, margin=margin)
    stop.on_click(lambda event: cancel())
    bar = pn.indicators.Progress(
        value=pn.bind(lambda f: round(100 * f), progress),
        max=100,
        width=200,
        visible=busy,
        margin=(34, 10) if below_label else (18, 10),
    )
    return run, stop, bar
