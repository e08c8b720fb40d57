"""The extra filters' estimates on the trajectory plots: one line per filter and coordinate, one colour each.

:class:`Overlay` adds, to each of the m stacked plots, a line per extra filter of :mod:`app.extras` (empty
until that filter is in the run), and a second legend row above the first plot listing only the filters
drawn. With no extra filter selected nothing is sent: the sources stay empty and the legend row hidden.
"""
from __future__ import annotations

import numpy as np
from bokeh.core.properties import value
from bokeh.models import ColumnDataSource, Legend, LegendItem
from bokeh.plotting import figure

from isl_core.baselines import LABELS

from ..extras import EXTRA_NAMES
from .style import EXTRA_COLORS

__all__ = ["LEGEND_ROW", "Overlay"]

LEGEND_ROW = 26  #: extra height of the first plot when the legend of the extra filters shows
_EMPTY = {"t": np.zeros(0, np.float32), "y": np.zeros(0, np.float32)}


class Overlay:
    """Lines of the extra filters on the trajectory figures (added with :meth:`add`, filled by :meth:`update`)."""

    def __init__(self) -> None:
        self._sources: list[dict[str, ColumnDataSource]] = []
        self._items: dict[str, LegendItem] = {}
        self._legend: Legend | None = None

    def add(self, fig: figure, i: int, k: str) -> None:
        """Lines for coordinate ``i`` (subscript ``k``) in ``fig``; the first figure also gets the legend row."""
        src = {n: ColumnDataSource(dict(_EMPTY), name=f"traj-{i + 1}-{n}") for n in EXTRA_NAMES}
        lines = {n: fig.line("t", "y", source=src[n], line_color=EXTRA_COLORS[n], line_width=1.5, line_alpha=0.9)
                 for n in EXTRA_NAMES}
        if i == 0:
            self._items = {n: LegendItem(label=value(f"{LABELS[n]}"), renderers=[lines[n]], visible=False)
                           for n in EXTRA_NAMES}
            self._legend = Legend(items=list(self._items.values()), orientation="horizontal", visible=False,
                                  label_text_font_size="11pt", click_policy="hide", padding=2, margin=2, spacing=14)
            fig.add_layout(self._legend, "above")
        else:  # the first figure's legend hides the lines of every plot together
            for n in EXTRA_NAMES:
                self._items[n].renderers[0].js_link("visible", lines[n], "visible")
        self._sources.append(src)

    def update(self, i: int, series: dict | None) -> None:
        """Data of plot ``i`` from the decimated ``series`` (None: the plot is not shown)."""
        for n, src in self._sources[i].items():
            if series is not None and n in series:
                t, y = series[n]
                src.data = {"t": t, "y": y}
            elif len(src.data["t"]):
                src.data = dict(_EMPTY)

    def show(self, names) -> bool:
        """Legend entries for ``names`` (the run's extra filters); True when the legend row is visible."""
        for n, item in self._items.items():
            item.visible = n in names
        shown = bool(names)
        if self._legend is not None:
            self._legend.visible = shown
        return shown
