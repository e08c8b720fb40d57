"""One tuning rule for every family's knob: the minimax of the period statistic over the table's scenarios.

Every filter family that does not know σ(t) has a knob (:data:`FAMILIES`): paper A's ISL filter and the
model-aware one ν (ν/β = 2^ℓ), the adaptive and the variational-Bayes filters their memory W in sensor readings
(:mod:`isl_core.filters.adaptive`), the robust filter Huber's c and its memory (jointly: the clipping changes what the
estimate averages, so the best W depends on c), the IMM filter its switch probability per reading and its number of
modes (jointly: a denser grid needs less switching to follow a change). On a grid of each knob
(:class:`TuningGrids`), every variant rides in **one** scenario run per preset and seed — common random numbers:
the same noise for all (:mod:`isl_core.scenario.tasks`) — and the period statistic of
:mod:`isl_core.scenario.periods` is taken per variant and cell (preset × period). A variant's **tuning curve** is its
statistic per cell against the knob; the family's knob is

    θ* = argmin_θ  max_cells ratio_θ(cell)                  (the minimax over the table's scenarios and periods)

and, as a reference, the **oracle-tuned** knob of a preset is argmin_θ max over that preset's periods (the best
tuning had one known the scenario). The rule is the same for every family; ties go to the first point of the grid.
:class:`Tuning` holds the curves and answers both; :func:`isl_core.tune` computes one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..filters.base import FilterSpec
from ..model import Model
from .base import Scenario
from .periods import Period, Worst, seed_ratios, worst_from
from .variants import FAMILIES, TuningGrids, family_filter

__all__ = ["Tuning"]


@dataclass(frozen=True)
class Tuning:
    """Every variant's period statistic per cell, from one run per preset and seed (module docstring).

    Filters (``names``, ``family``, ``knobs``): the clairvoyant reference, the Kalman–Bucy filter for σ(0), paper A's
    ISL filter at its table's ν (``family`` "isl_paper"; ν = β where table (A.31) has no value for this α), then every
    variant of every family. ``cells`` are (preset index, period); ``y`` (seeds, cells, filters, m) the seeds'
    contributions per coordinate (:func:`!isl_core.scenario.periods.per_seed`); a cell's figure is its worst
    coordinate's. Per preset: ``reading_time`` one reading in units of 1/r_min at σ(0) (W readings are
    W·reading_time), ``steps`` N, ``h``, ``substeps`` q (Euler steps per reading), and in ``scenarios`` its (σ(0),
    :class:`Scenario`) as run, at the reading ``rate`` (readings per 1/r_min at σ(0); None: a reading every step) with
    the step halved ``refine`` times below the coarsest that serves every variant (:func:`isl_core.scenario_grid`).
    ``origin`` says where it came from.
    """

    alpha: float
    m: int
    w: float
    seeds: tuple[int, ...]
    horizon: float
    burn: float
    grids: TuningGrids
    presets: tuple[str, ...]
    preset_labels: tuple[str, ...]
    cells: tuple[tuple[int, Period], ...]
    names: tuple[str, ...]
    family: tuple[str, ...]
    knobs: tuple[dict[str, Any], ...]  # numbers, but the paper row's ν label
    y: np.ndarray
    reading_time: tuple[float, ...]
    steps: tuple[int, ...]
    h: tuple[float, ...]
    seconds: float
    scenarios: tuple[tuple[float, Scenario], ...] = ()
    origin: str = ""
    rate: float | None = None
    refine: int = 0
    substeps: tuple[int, ...] = ()
    _stats: dict[float, Worst] = field(default_factory=dict, repr=False, compare=False)

    def stats(self, level: float = 0.95) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(ratio, low, high), each (filters, cells): the period statistic at the worst coordinate and its interval
        at ``level`` (:func:`!isl_core.scenario.periods.worst_from`)."""
        if level not in self._stats:
            self._stats[level] = worst_from(self.y, level)
        return self._stats[level][:3]

    def coordinate(self) -> np.ndarray:
        """The worst coordinate (0-based) per filter and cell (filters, cells)."""
        self.stats()
        return self._stats[0.95][3]

    def seed_ratios(self) -> np.ndarray:
        """Each seed's own worst-coordinate ratio (seeds, cells, filters)."""
        return seed_ratios(self.y)

    def preset_map(self) -> dict[str, tuple[str, float, Scenario]]:
        """The presets this tuning was computed over, as :func:`isl_core.tune` takes them."""
        return {
            n: (lab, s0, sc) for n, lab, (s0, sc) in zip(self.presets, self.preset_labels, self.scenarios, strict=True)
        }

    def variants(self, family: str) -> np.ndarray:
        """Indices of the family's variants, in grid order."""
        return np.flatnonzero(np.array(self.family) == family)

    def preset_cells(self, preset: int) -> np.ndarray:
        """Indices of the cells of preset number ``preset``."""
        return np.array([c for c, (p, _) in enumerate(self.cells) if p == preset])

    def _argmin_max(self, family: str, cells: np.ndarray) -> int:
        idx = self.variants(family)
        worst = self.stats()[0][np.ix_(idx, cells)].max(axis=1)
        return int(idx[np.argmin(np.where(np.isnan(worst), np.inf, worst))])

    def minimax(self, family: str) -> int:
        """The family's tuned variant: the least, over its grid, of its largest ratio over every cell."""
        return self._argmin_max(family, np.arange(len(self.cells)))

    def on_edge(self, family: str) -> dict[str, str]:
        """The knobs of the family's minimax variant that sit at an end of their grid, knob → "lowest"/"highest" (a
        minimax on an edge is no bracketed optimum: :ref:`findings-grids`); empty when every knob is inside."""
        knob, points = self.knobs[self.minimax(family)], self.grids.points(family)
        out = {}
        for name, value in knob.items():
            values = sorted({p[name] for p in points})
            if len(values) > 1 and value in (values[0], values[-1]):
                out[name] = "lowest" if value == values[0] else "highest"
                if name == "memory" and value == values[0]:  # the grid starts at the limit of W: see the grids
                    out[name] += ": the hard limit W = 1" if value == 1.0 else ": W > 1 is its hard limit"
        return out

    def oracle(self, family: str, preset: int) -> int:
        """The family's best variant for one preset (oracle-tuned): least largest ratio over that preset's cells."""
        return self._argmin_max(family, self.preset_cells(preset))

    def filter(self, index: int, model: Model) -> FilterSpec:
        """The filter ``index`` (a variant) for ``model``, e.g. the tuned one of a family for a dashboard."""
        return family_filter(self.family[index], model, self.knobs[index], self.grids)

    def tuned_filters(self, model: Model) -> list[FilterSpec]:
        """Every family's minimax-tuned filter for ``model``, in :data:`FAMILIES` order."""
        return [self.filter(self.minimax(f), model) for f in FAMILIES]

    def grid_filters(self, model: Model) -> list[FilterSpec]:
        """Every variant for ``model``: given as ``grid_filters`` to :func:`isl_core.plan_scenario`, a run
        of a few filters gets the tuning's grid h — so W readings of a sensor read at every step span the time they
        spanned in the tuning (``reading_time``) — and, with the same seeds, its noise."""
        return [self.filter(j, model) for j in range(3, len(self.names))]
