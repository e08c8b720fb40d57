"""A table's cells as statistics: per row and cell the worst coordinate's ratio with its interval, every coordinate's,
the worst seed and the seeds above 2× or diverged (:class:`CellStats`); the σ range each row assumes; and the rows run
through the presets beyond every assumed range (:data:`isl_core.scenario.presets.BEYOND`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from ..filters.base import SIGMA_RANGE
from .periods import seed_ratios, worst_from
from .variants import TuningGrids

if TYPE_CHECKING:
    from .heldout import HeldOut


class _Row(Protocol):
    @property
    def role(self) -> str: ...

    @property
    def columns(self) -> tuple[int, ...]: ...


class _Table(Protocol):
    """What the rows beyond every assumed range read of a table (:class:`~isl_core.scenario.table.ScenarioTable`,
    which imports this module)."""

    @property
    def held(self) -> HeldOut | None: ...

    @property
    def rows(self) -> Sequence[_Row]: ...

    @property
    def level(self) -> float: ...


__all__ = ["CellStats", "assumes", "beyond_rows", "beyond_stats", "cell_stats"]


def assumes(family: str, knob: Mapping[str, float], grids: TuningGrids) -> str:
    """The σ range a family's filter assumes, in words (:data:`isl_core.filters.base.SIGMA_RANGE` for the learners
    with a gain table, the IMM's grid; none for the ISL filters and variational Bayes)."""
    lo, hi = SIGMA_RANGE
    if family in ("isl", "isl_model", "isl_paper"):
        return "none: no σ, no range of σ"
    if family in ("kbf_adaptive", "kbf_robust"):
        return f"σ in [{lo:g}, {hi:g}]: its gain table's range, σ̂ held inside it"
    if family == "vb":
        return f"no range: a prior on σ² at σ̂ = {(lo * hi) ** 0.5:g}, forgotten over W readings; σ̂ unbounded"
    if family == "imm":
        return f"σ on {knob['modes']:g} modes over [{grids.imm_sigma_range[0]:g}, {grids.imm_sigma_range[1]:g}]"
    return ""


@dataclass(frozen=True)
class CellStats:
    """Per row and cell: the worst coordinate's ``ratio`` with ``low``/``high``, that ``coordinate`` (0-based) and
    every coordinate's ratio (``coordinates``, rows × cells × m), the worst seed's own ratio ``worst_seed`` on seed
    ``worst_seed_id``, the seeds above 2× (``above2``) and the seeds that diverged (``diverged``)."""

    ratio: np.ndarray
    low: np.ndarray
    high: np.ndarray
    coordinate: np.ndarray
    coordinates: np.ndarray
    worst_seed: np.ndarray
    worst_seed_id: np.ndarray
    above2: np.ndarray
    diverged: np.ndarray


def cell_stats(ys: list[np.ndarray], seeds: list[tuple[int, ...]], level: float) -> CellStats:
    """:class:`CellStats` of the rows' contributions ``ys`` (each seeds × cells × m) on their ``seeds``."""
    stats = [worst_from(y[:, :, None, :], level) for y in ys]  # each (1, cells)
    ratio, low, high, coordinate = (np.array([st[k][0] for st in stats]) for k in range(4))
    coordinates = np.array([np.sqrt(y.mean(axis=0)) for y in ys])
    ratios_s = [seed_ratios(y) for y in ys]  # each seed's own ratio (seeds, cells), per row
    with np.errstate(invalid="ignore"):
        worst_seed = np.array([np.max(sr, axis=0) for sr in ratios_s])
    worst_id = np.array(
        [
            [seeds[r][int(np.argmax(np.where(np.isnan(sr[:, c]), np.inf, sr[:, c])))] for c in range(sr.shape[1])]
            for r, sr in enumerate(ratios_s)
        ]
    )
    above2 = np.array([(sr > 2.0).sum(axis=0) for sr in ratios_s])
    diverged = np.array([(~np.isfinite(sr)).sum(axis=0) for sr in ratios_s])
    return CellStats(ratio, low, high, coordinate, coordinates, worst_seed, worst_id, above2, diverged)


def beyond_stats(table: _Table) -> CellStats | None:
    """The table's reference, tuned and paper rows (in that order: :func:`beyond_rows`) over the held-out run's
    presets beyond every assumed range, or None without them."""
    held = table.held
    if held is None or not held.beyond_cells:
        return None
    rows = beyond_rows(table)
    ys = [held.beyond_y[:, :, held.columns.index(table.rows[r].columns[0])] for r in rows]
    return cell_stats(ys, [held.seeds] * len(rows), table.level)


def beyond_rows(table: _Table) -> list[int]:
    """The rows run through the presets beyond every assumed range: all but the oracle rows."""
    return [r for r, row in enumerate(table.rows) if row.role != "oracle"]
