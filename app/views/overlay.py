"""The extra filters' estimates on the trajectory plots: one line per filter and coordinate, one colour each.

:class:`Overlay` adds, to each of the m stacked plots, a line per extra filter of :mod:`app.extras` (empty
until that filter is in the run), and to the trajectories' legend an entry per filter, shown only while that
filter is drawn. With no extra filter selected nothing is sent: the sources stay empty, their lines and legend
entries hidden (a hidden line costs the browser nothing on a redraw; an empty visible one still goes through
painting).
"""

from __future__ import annotations

import numpy as np
from bokeh.core.properties import value
from bokeh.models import ColumnDataSource, GlyphRenderer, LegendItem
from bokeh.plotting import figure

from isl_core.filters.baselines import LABELS

from ..extras import EXTRA_NAMES
from .batch import one_walk
from .style import EXTRA_COLORS, EXTRA_DASHES, line

__all__ = ["KEY_DATA", "Overlay", "follow"]

_EMPTY = {"t": np.zeros(0, np.float32), "y": np.zeros(0, np.float32)}
#: data of a legend key: a legend entry draws its glyph only if it has data; these two points lie outside the
#: legend figure's ranges, so the figure itself shows nothing
KEY_DATA = {"t": np.array([-2.0, -1.0], np.float32), "y": np.array([-2.0, -1.0], np.float32)}


def follow(key: GlyphRenderer) -> list:
    """The list of models whose ``visible`` follows the legend key ``key`` (append the models to it).

    A legend redraws whenever any model it references, however indirectly, changes; a browser-side link from
    the key to the plotted lines would make it reference every line, source and view of the plots, and redraw on
    every run. So the link runs on the server: a click on the entry changes the
    key's ``visible``, and this callback hides or shows the followers (one round trip, on a click only).
    """
    followers: list = []

    def changed(attr, old, new) -> None:
        for model in followers:
            model.visible = new

    key.on_change("visible", changed)
    return followers


def _style(n: str) -> dict:
    return {"line_color": EXTRA_COLORS[n], "line_width": 2.0, "line_alpha": 0.95, "line_dash": EXTRA_DASHES[n]}


class Overlay:
    """Lines of the extra filters on the trajectory figures (added with :meth:`add`, filled by :meth:`update`).

    ``key_figure`` is the legend's figure: each filter gets an unseen line there, the glyph of its legend entry;
    hiding it (a click on the entry) hides that filter's line in every plot.
    """

    def __init__(self, key_figure: figure) -> None:
        self._keys: dict[str, GlyphRenderer] = {
            n: key_figure.line("t", "y", source=ColumnDataSource(dict(KEY_DATA)), visible=False, **_style(n))
            for n in EXTRA_NAMES
        }
        self.items = [LegendItem(label=value(LABELS[n]), renderers=[self._keys[n]], visible=False) for n in EXTRA_NAMES]
        self._followers = {n: follow(key) for n, key in self._keys.items()}
        self._figures: list[figure] = []
        self._sources: list[dict[str, ColumnDataSource]] = []
        self._shown: set[str] = set()
        self._expected: set[str] = set()

    def expect(self, names) -> None:
        """The filters the page opens with (a link's ``extra_filters``): their lines are built with the plots, while
        the page is built, hidden until the first run shows them. Built when that run arrived, on the event loop,
        each line's addition re-walked every model of the page: 0.7 s of the loop for a page at m = 6 with every
        filter."""
        self._expected = set(names)
        for i, sources in enumerate(self._sources):
            for n in sorted(self._expected - sources.keys()):
                self._line(i, n)

    def add(self, fig: figure, i: int) -> None:
        """Register ``fig`` as the plot of coordinate ``i``: the lines of the filters shown or expected are built at
        once, the others when their filter is first shown (each costs 8 models; most pages never show them)."""
        self._figures.append(fig)
        self._sources.append({})
        for n in sorted(self._shown | self._expected):
            self._line(i, n)

    def _line(self, i: int, n: str) -> None:
        src = self._sources[i][n] = ColumnDataSource(dict(_EMPTY), name=f"traj-{i + 1}-{n}")
        self._followers[n].append(line(self._figures[i], src, visible=self._keys[n].visible, **_style(n)))

    def update(self, i: int, series: dict | None) -> None:
        """Data of plot ``i`` from the decimated ``series`` (None: the plot is not shown)."""
        for n, src in self._sources[i].items():
            if series is not None and n in series:
                t, y = series[n]
                src.data = {"t": t, "y": y}
            elif len(src.data["t"]):
                src.data = dict(_EMPTY)

    def show(self, names) -> int:
        """Legend entries and lines for ``names`` (the run's extra filters); returns how many are shown.

        A newly drawn filter shows (its key and its lines, set here: a key's ``on_change`` callback runs for a
        click in the browser, not for a change made on the server); a filter already drawn keeps whatever a
        legend click made of it.
        """
        building = any(n not in sources for n in names for sources in self._sources)
        # lines built here (a filter ticked on a live page): the page's models are re-walked once, not once a line
        with one_walk(self._keys[EXTRA_NAMES[0]], building):
            for n, item in zip(EXTRA_NAMES, self.items, strict=True):
                item.visible = n in names
                if (n in names) != (n in self._shown):
                    self._keys[n].visible = n in names
                    for i, sources in enumerate(self._sources):
                        if n in names and n not in sources:
                            self._line(i, n)
                    for renderer in self._followers[n]:
                        renderer.visible = n in names
        self._shown = set(names)
        return len(self._shown)
