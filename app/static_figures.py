"""Static files of paper A's figures: PNG through matplotlib (Agg, no pyplot state) and HTML through bokeh.

* Fig. 2 — ratio š_i/s_i against ν/β (log axis): rows α, columns i, σ = 2 dotted, 20 dashed, 200 solid;
  simulated points with their confidence interval, the statistical-linearization theory (:ref:`linearization`) as a thin
  long-dashed line of the same colour.
* Fig. 3 — one trajectory per σ: X_i black, Kalman–Bucy X̂_i green, ISL X̌_i blue (:mod:`app.colors`, the
  dashboard's own), X̂_i ± 3 s_i dashed green,
  every other filter of the run in its dashboard colour. The same renderer draws ``isl figure3``'s PNG and the
  dashboard's "Download figure (PNG)": all rows, the legend and every parameter in the title.

Views only: they take :class:`isl_core.SweepResult` / :class:`isl_core.runview.RunView` objects and never compute;
the trajectories come decimated by the core (:mod:`isl_core.decimate`, the project's one decimation function).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .colors import EXTRA_COLORS, ISL, KBF, TRUTH

__all__ = ["COORD_NAMES", "SIGMA_DASH", "fig2_html", "fig2_png", "fig3_html", "fig3_png"]

SIGMA_DASH = ("dotted", "dashed", "solid")  #: paper A's line styles for σ = 2, 20, 200 (by rank of σ)
_MPL_DASH = {"dotted": ":", "dotdash": (0, (1, 2, 4, 2)), "dashdot": "-.", "dashed": "--", "solid": "-"}
_COLORS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#8c564b", "#e377c2")
THEORY_DASH = (0, (8, 3))  #: long dashes for theory (matplotlib); bokeh: "8 3"
COORD_NAMES = ("position", "velocity", "acceleration", "jerk", "snap", "crackle")


def _sigma_styles(sigmas) -> list[str]:
    """Line style per σ by rank (smallest dotted … largest solid): paper A's 2 / 20 / 200 → dotted / dashed / solid."""
    n = len(sigmas)
    if n == 1:
        return ["solid"]
    styles = SIGMA_DASH if n <= 3 else ("dotted", "dotdash", "dashdot", "dashed", "solid")
    ranks = np.argsort(np.argsort(sigmas))
    return [styles[round(r * (len(styles) - 1) / (n - 1))] for r in ranks]


def _coord(i: int) -> str:
    return f"X_{i + 1} ({COORD_NAMES[i]})" if i < len(COORD_NAMES) else f"X_{i + 1}"


def fig2_png(res, path: str | Path, *, dpi: int = 110) -> Path:
    """Fig. 2 of paper A as a PNG, from an :class:`isl_core.SweepResult`."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FuncFormatter, NullFormatter

    na, ns, m = len(res.alphas), len(res.sigmas), res.m
    fig = Figure(figsize=(3.6 * m, 2.6 * na + 0.6), layout="constrained")
    axes = fig.subplots(na, m, squeeze=False, sharex=True)
    x = res.nu_over_beta
    styles = _sigma_styles(res.sigmas)
    plain = FuncFormatter(lambda v, _: f"{v:g}")
    for a in range(na):
        for i in range(m):
            ax = axes[a, i]
            for b in range(ns):
                col = _COLORS[b % len(_COLORS)]
                y = res.ratio[a, b, :, i]
                err = np.vstack([y - res.ratio_low[a, b, :, i], res.ratio_high[a, b, :, i] - y])
                ax.errorbar(x, y, yerr=err, color=col, ls=_MPL_DASH[styles[b]], marker="o", ms=2.5, lw=1.2, capsize=1.5)
                ax.plot(x, res.theory[a, b, :, i], color=col, ls=THEORY_DASH, lw=0.8, alpha=0.7)
            ax.axhline(1.0, color="0.6", lw=0.6)
            ax.set_xscale("log", base=2)
            ax.set_yscale("log")
            ax.yaxis.set_major_formatter(plain)
            lo, hi = ax.get_ylim()
            ax.yaxis.set_minor_formatter(plain if hi / lo < 12 else NullFormatter())
            if a == 0:
                ax.set_title(f"i = {i + 1}: š_{i + 1}/s_{i + 1}")
            if i == 0:
                ax.set_ylabel(f"α = {res.alphas[a]:g}")
            if a == na - 1:
                ax.set_xlabel("ν/β")
    handles = [
        Line2D(
            [],
            [],
            color=_COLORS[b % len(_COLORS)],
            ls=_MPL_DASH[styles[b]],
            marker="o",
            ms=2.5,
            label=f"σ = {res.sigmas[b]:g} (simulated)",
        )
        for b in range(ns)
    ]
    handles.append(Line2D([], [], color="0.4", ls=THEORY_DASH, lw=0.8, label="theory (statistical linearization)"))
    axes[0, -1].legend(handles=handles, fontsize=7, loc="best")
    model = f"β = {res.beta:g}" if res.beta is not None else f"w = {res.w:g}"
    fig.suptitle(
        f"ISL / optimal RMSE ratio (m = {m}, {model}; horizon {res.horizon:g}/r_min × "
        f"{len(res.seeds)} seeds; {res.level:.0%} intervals)",
        fontsize=9,
    )
    path = Path(path)
    fig.savefig(path, dpi=dpi)
    return path


def _save_html(layout, path: str | Path, title: str) -> Path:
    from bokeh.embed import file_html
    from bokeh.resources import INLINE

    path = Path(path)
    path.write_text(file_html(layout, INLINE, title), encoding="utf-8")
    return path


def fig2_html(res, path: str | Path) -> Path:
    """Fig. 2 of paper A as a self-contained HTML page (bokeh, resources inline)."""
    from bokeh.layouts import gridplot
    from bokeh.models import ColumnDataSource, Whisker
    from bokeh.plotting import figure

    na, ns, m = len(res.alphas), len(res.sigmas), res.m
    grid, x_range = [], None
    for a in range(na):
        row = []
        for i in range(m):
            p = figure(
                width=330,
                height=230,
                x_axis_type="log",
                y_axis_type="log",
                title=f"α = {res.alphas[a]:g}, i = {i + 1}",
                tools="pan,wheel_zoom,box_zoom,reset,save,hover",
                tooltips=[("ν/β", "@x"), ("ratio", "@y"), ("theory", "@theory"), ("σ", "@sigma")],
                **({} if x_range is None else {"x_range": x_range}),
            )
            x_range = x_range or p.x_range
            for b in range(ns):
                col = _COLORS[b % len(_COLORS)]
                style = _sigma_styles(res.sigmas)[b]
                src = ColumnDataSource(
                    dict(
                        x=res.nu_over_beta,
                        y=res.ratio[a, b, :, i],
                        lo=res.ratio_low[a, b, :, i],
                        hi=res.ratio_high[a, b, :, i],
                        theory=res.theory[a, b, :, i],
                        sigma=np.full(len(res.nu_over_beta), res.sigmas[b]),
                    )
                )
                legend = f"σ = {res.sigmas[b]:g}"
                p.line("x", "y", source=src, color=col, line_dash=style, line_width=1.5, legend_label=legend)
                p.scatter("x", "y", source=src, color=col, size=4, legend_label=legend)
                p.add_layout(Whisker(source=src, base="x", lower="lo", upper="hi", line_color=col))
                p.line(
                    "x",
                    "theory",
                    source=src,
                    color=col,
                    line_dash="8 3",
                    line_width=1,
                    alpha=0.7,
                    legend_label="theory",
                )
            p.xaxis.axis_label = "ν/β" if a == na - 1 else ""
            p.legend.label_text_font_size = "7pt"
            p.legend.click_policy = "hide"
            row.append(p)
        grid.append(row)
    return _save_html(gridplot(grid), path, "isl — paper A, Fig. 2")


def _fig3_lines(view, i: int) -> list[tuple[str, np.ndarray, np.ndarray, dict]]:
    """Coordinate i of a :class:`isl_core.runview.RunView` as ``(label, t, y, style)`` lines: X, X̂, X̌, the tube
    X̂ ± 3 s (one label) and each other filter's estimate. Styles are matplotlib's; ``ls`` "--" is dashed."""
    kbf, isl = view.tracks[0].estimate[i], view.tracks[1].estimate[i]
    tube = 3.0 * float(view.s[i])
    lines = [
        ("X (truth)", view.truth[i].t, view.truth[i].y, {"color": TRUTH, "lw": 0.9}),
        ("X̂ (Kalman–Bucy, knows σ)", kbf.t, kbf.y, {"color": KBF, "lw": 0.9}),
        ("X̌ (ISL, σ unknown)", isl.t, isl.y, {"color": ISL, "lw": 0.9}),
        ("X̂ ± 3s (optimal RMSE)", kbf.t, kbf.y - tube, {"color": KBF, "ls": "--", "lw": 0.7}),
        ("", kbf.t, kbf.y + tube, {"color": KBF, "ls": "--", "lw": 0.7}),
    ]
    for tr in view.tracks[2:]:
        est = tr.estimate[i]
        lines.append((tr.label, est.t, est.y, {"color": EXTRA_COLORS.get(tr.name, "gray"), "lw": 0.8}))
    return lines


def _fig3_title(view, sep: str = " ") -> str:
    """The run's parameters (``sep`` between σ, the model and the grid: a new line where a column is narrow)."""
    md = view.model
    return (
        f"σ = {md.sigma:g}{sep}(m = {md.m}, α = {md.alpha:g}, β = {md.beta:g}, ν = {view.nu:g}, seed {view.seed},"
        f"{sep}T = {view.T:.4g} = {view.horizon:.3g}/rₘᵢₙ, N = {view.N:,})"
    )


def fig3_png(views, path, *, dpi: int = 110, note: str = "", font: float = 1.0):
    """Fig. 3 of paper A as a PNG: one column per run (σ), one row per coordinate, the legend below the plots and
    the parameters above each column, on two lines (``note``: a line above the figure, e.g. the measured ratios).
    ``views``: :class:`isl_core.runview.RunView` objects; ``path``: a file name or a binary file object; ``font``
    scales every text (the dashboard's picture is shown smaller than it is drawn)."""
    from matplotlib.figure import Figure

    m = views[0].model.m
    fig = Figure(figsize=(max(6.4 * len(views), 9.0), 2.3 * m + 2.0), layout="constrained")
    axes = fig.subplots(m, len(views), squeeze=False)
    for c, view in enumerate(views):
        for i in range(m):
            ax = axes[i, c]
            for label, t, y, style in _fig3_lines(view, i):
                ax.plot(t, y, label=label or None, **style)
            ax.set_ylabel(_coord(i), fontsize=10 * font)
            ax.tick_params(labelsize=9 * font)
            if i == 0:
                ax.set_title(_fig3_title(view, "\n"), fontsize=9.5 * font)
            if i == m - 1:
                ax.set_xlabel("t", fontsize=10 * font)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(
        handles,
        labels,
        loc="outside lower center",
        ncols=min(len(labels), 2 if len(views) == 1 else 4),
        fontsize=9.5 * font,
    )
    if note:
        fig.suptitle(note, fontsize=9.5 * font)
    fig.savefig(path, dpi=dpi, format="png")
    return Path(path) if isinstance(path, str | Path) else path


def fig3_html(runs, path: str | Path) -> Path:
    """Fig. 3 of paper A as a self-contained HTML page: one column per run (σ), shared time axis per column."""
    from bokeh.layouts import gridplot
    from bokeh.plotting import figure

    m = runs[0].model.m
    cols = []
    for run in runs:
        col, x_range = [], None
        for i in range(m):
            p = figure(
                width=520,
                height=210,
                title=_fig3_title(run) if i == 0 else None,
                tools="pan,xwheel_zoom,box_zoom,reset,save",
                **({} if x_range is None else {"x_range": x_range}),
            )
            x_range = x_range or p.x_range
            tube = ""
            for label, t, y, style in _fig3_lines(run, i):
                tube = label or tube  # the tube's upper edge shares the lower edge's legend entry
                p.line(
                    t,
                    y,
                    color=style["color"],
                    line_dash="dashed" if style.get("ls") == "--" else "solid",
                    legend_label=label or tube,
                )
            p.yaxis.axis_label = _coord(i)
            p.legend.label_text_font_size = "7pt"
            p.legend.click_policy = "hide"
            col.append(p)
        col[-1].xaxis.axis_label = "t"
        cols.append(col)
    grid = [[cols[c][i] for c in range(len(cols))] for i in range(m)]
    return _save_html(gridplot(grid), path, "isl — paper A, Fig. 3")
