"""Who wins where, in a fair contest: every family at its minimax tuning, on the period statistic, per scenario,
reported on seeds the tuning never saw.

:func:`scenario_table` takes the tuning of :func:`isl_core.tune` (one run per preset and seed with every
variant of every family on the same noise; cached) and the held-out runs of :func:`!isl_core.scenario.heldout.held_out`
(the table's filters again, on report seeds disjoint from the tuning's and four times as many) and reports, per row
and cell (preset × period of :func:`isl_core.scenario_periods`), the period statistic at the worst
coordinate — each coordinate's RMSE pooled over the seeds over the clairvoyant filter's exact variance, the largest
of them — with Student's interval over the seeds, the coordinate, the worst seed's own ratio and how many seeds read
above 2×:

* **references** — the clairvoyant filter (knows σ(t); reads 1 up to sampling error: the check of the denominator)
  and the Kalman–Bucy filter optimal for σ(0) (knows σ at the start, learns nothing);
* **tuned** — each family of :data:`isl_core.FAMILIES` (none knows σ(t)) at its minimax knob, the one
  tuning rule: the least, over the knob's grid, of the largest ratio over every cell of the table, on the tuning's
  seeds;
* **paper** — paper A's ISL filter at table (A.31)'s ν, the paper's own value (where the table has this α);
* **oracle-tuned** — each family at the best knob *per preset* (a reference: the tuning one would pick knowing the
  scenario; its knob is given per preset), read on the tuning's seeds, as they were chosen.

Every row says its tuning, its origin, the σ range it assumes, and which seeds its figures come from. A tuned row's
**tuning-seed figure** is its largest cell on the tuning's seeds (the minimax value) with that cell's interval; its
**held-out figure** is its largest cell on the report seeds. A row whose held-out figure leaves the tuning-seed
interval is **flagged**: its verdict did not hold out of sample. A preset's number is a row's largest ratio over the
preset's periods; the winner of a cell is the lowest of the tuned and paper rows, with the margin over the runner-up
and its conservative lower bound (:func:`!isl_core.scenario.periods.worst_margin`) — a tie where that bound is ≤ 1.
Times are in units of 1/r_min of the model at σ(0).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..paper import M, W
from ..requests import Execution, Sampling
from ..validate import check_real
from .base import Scenario
from .cells import CellStats, assumes, beyond_rows, beyond_stats, cell_stats
from .heldout import HeldOut, held_out
from .minimax import Tuning
from .periods import worst_margin
from .presets import DEFAULT_RATE, PRESETS
from .tasks import local_threads
from .tuning import tune, tuning_sampling
from .variants import FAMILIES, TuningGrids

__all__ = [
    "PRESETS",
    "CellStats",
    "ScenarioTable",
    "TableRow",
    "beyond_rows",
    "beyond_stats",
    "knob_text",
    "scenario_table",
    "table_from",
]


@dataclass(frozen=True)
class TableRow:
    """One row: ``name`` (stable: the family, or ``oracle:<family>``), ``label``, ``role`` ("reference", "tuned",
    "paper", "oracle"), what it ``knows`` of σ and what σ range it ``assumes``, its ``tuning`` (knob → value; per
    preset for an oracle row), its ``origin`` and ``columns``, per preset the index of its filter in the tuning's
    run."""

    name: str
    label: str
    role: str
    knows: str
    tuning: dict[str, Any] | tuple[dict[str, Any], ...]
    origin: str
    columns: tuple[int, ...]
    assumes: str = ""


@dataclass(frozen=True)
class ScenarioTable:
    """Per row (``rows``) and cell (``tuning.cells``: preset index, period) the :class:`CellStats` ``stats`` at
    ``level``: the worst coordinate's ratio with its interval, every coordinate's, the worst seed and the seeds above
    2× or diverged; ``seeds[r]`` the seeds a row's figures come from (the report seeds, or the tuning's for an oracle
    row, or for every row without a held-out run). Per row the tuning-seed figure ``tuned_figure`` (its largest cell
    on the tuning's seeds) with that cell's interval ``tuned_low``/``tuned_high``, and ``held_figure`` (its largest
    cell on the report seeds); ``flagged`` where a tuned or paper row's held-out figure leaves that interval.
    :meth:`preset` the largest over a preset's cells; per cell ``winner``/``runner_up`` (row indices among the tuned
    and paper rows), ``margin`` (the runner-up's ratio over the winner's) and ``margin_low`` its conservative lower
    bound; ``tie`` where that bound is ≤ 1."""

    tuning: Tuning
    rows: tuple[TableRow, ...]
    stats: CellStats
    level: float
    winner: np.ndarray
    runner_up: np.ndarray
    margin: np.ndarray
    margin_low: np.ndarray
    seeds: tuple[tuple[int, ...], ...]
    tuned_figure: np.ndarray
    tuned_low: np.ndarray
    tuned_high: np.ndarray
    held_figure: np.ndarray
    flagged: np.ndarray
    held: HeldOut | None = None

    @property
    def tie(self) -> np.ndarray:
        """Per cell, whether the winner and the runner-up tie (the margin's lower bound ≤ 1)."""
        return self.margin_low <= 1.0

    def preset(self, p: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per row, the largest ratio over preset ``p``'s periods and the largest ends of their intervals."""
        cells, st = self.tuning.preset_cells(p), self.stats
        return (st.ratio[:, cells].max(axis=1), st.low[:, cells].max(axis=1), st.high[:, cells].max(axis=1))


KNOB_TEXT = {
    "ell": lambda v: f"ν/β = 2^{v:g} = {2.0**v:.3g}",
    "memory": lambda v: f"W = {v:g} readings",
    "c": lambda v: f"c = {v:g}",
    "switch": lambda v: f"switch {v:g} a reading",
    "modes": lambda v: f"{v:g} modes",
}


def knob_text(knob: Mapping[str, float]) -> str:
    """A knob in words: ``ν/β = 2^-2 = 0.25``, ``W = 30 readings``, ``c = 2, W = 10 readings``."""
    return ", ".join(KNOB_TEXT[k](v) if k in KNOB_TEXT else f"{k} = {v}" for k, v in knob.items())


def _rows(tuning: Tuning) -> list[TableRow]:
    npre, grids = len(tuning.presets), tuning.grids
    rows = [
        TableRow(
            "clairvoyant",
            "Kalman filter that knows σ(t) (clairvoyant)",
            "reference",
            "σ(t)",
            {},
            "the reference: its exact covariance P is every ratio's denominator",
            (0,) * npre,
            "σ(t) itself",
        ),
        TableRow(
            "kbf",
            "Kalman–Bucy for constant σ = σ(0)",
            "reference",
            "σ(0)",
            {},
            "the stationary filter of σ(0) (A.21–A.23)",
            (1,) * npre,
            "σ = σ(0)",
        ),
    ]
    for fam, (label, _) in FAMILIES.items():
        j = tuning.minimax(fam)
        knob = dict(tuning.knobs[j])
        rows.append(
            TableRow(
                fam,
                f"{label}, {knob_text(knob)}",
                "tuned",
                "nothing of σ",
                knob,
                tuning.origin,
                (j,) * npre,
                assumes(fam, knob, grids),
            )
        )
    if "(A.31)" in tuning.knobs[2]["paper"]:
        rows.append(
            TableRow(
                "isl_a31",
                tuning.knobs[2]["paper"],
                "paper",
                "nothing of σ",
                {},
                "paper A, table (A.31): the ν/β the authors read off their Fig. 2",
                (2,) * npre,
                assumes("isl_paper", {}, grids),
            )
        )
    for fam, (label, _) in FAMILIES.items():
        cols = tuple(tuning.oracle(fam, p) for p in range(npre))
        rows.append(
            TableRow(
                f"oracle:{fam}",
                f"{label}, oracle-tuned (best knob per preset)",
                "oracle",
                "nothing of σ",
                tuple(dict(tuning.knobs[j]) for j in cols),
                "the least largest ratio over each preset's periods, on the tuning's seeds",
                cols,
                "; ".join(dict.fromkeys(assumes(fam, tuning.knobs[j], grids) for j in cols)),
            )
        )
    return rows


def _row_y(y: np.ndarray, cols: np.ndarray, index: Callable[[int], int]) -> np.ndarray:
    """One row's contributions (seeds, cells, m) from ``y`` (seeds, cells, filters, m), its filter per cell ``cols``
    mapped to ``y``'s filter axis by ``index``."""
    return np.stack([y[:, c, index(int(j))] for c, j in enumerate(cols)], axis=1)


def table_from(tuning: Tuning, level: float = 0.95, held: HeldOut | None = None) -> ScenarioTable:
    """The fair table (module docstring) of a :class:`isl_core.Tuning`, its cells read on the report
    seeds of ``held`` (:func:`!isl_core.scenario.heldout.held_out`) — or, without it, on the tuning's own seeds.

    Parameters
    ----------
    tuning : Tuning
        The result of :func:`isl_core.tune`.
    level : float, default 0.95
        Confidence level of the intervals.
    held : HeldOut, optional
        The table's filters on the report seeds.

    Returns
    -------
    ScenarioTable
        As :func:`scenario_table`.

    Examples
    --------
    >>> from isl_core import Execution, Sampling, TuningGrids, table_from, tune
    >>> from isl_core.scenario import PRESETS
    >>> grids = TuningGrids(isl_ell=(-2.0, 0.0), memory=(100.0,), robust_c=(2.0,), imm_switch=(1e-3,), imm_modes=(6,))
    >>> tuning = tune(1.0, presets={"sigma_drop": PRESETS["sigma_drop"]}, grids=grids,
    ...               sampling=Sampling.first(2, horizon=15.0, burn=2.0), execution=Execution(workers=1, cache=False))
    >>> table_from(tuning, level=0.9).level
    0.9
    """
    level = check_real("level", level, lo=0.5, hi=1.0, hi_open=True)
    rows = _rows(tuning)
    cells = range(len(tuning.cells))
    col = np.array([[row.columns[tuning.cells[c][0]] for c in cells] for row in rows])  # (rows, cells)
    ys, seeds = [], []
    for r, row in enumerate(rows):
        if held is not None and row.role != "oracle":
            ys.append(_row_y(held.y, col[r], held.columns.index))
            seeds.append(held.seeds)
        else:
            ys.append(_row_y(tuning.y, col[r], lambda j: j))
            seeds.append(tuning.seeds)
    stats = cell_stats(ys, seeds, level)
    ratio = stats.ratio
    t_ratio, t_low, t_high = tuning.stats(level)
    worst_cell = np.array([int(np.argmax(np.nan_to_num(t_ratio[col[r], cells], nan=np.inf))) for r in range(len(rows))])
    pick: Callable[[np.ndarray], np.ndarray] = lambda a: np.array([a[col[r, c], c] for r, c in enumerate(worst_cell)])  # noqa: E731
    tuned_figure, tuned_low, tuned_high = pick(t_ratio), pick(t_low), pick(t_high)
    held_figure = np.where(np.isnan(ratio), np.inf, ratio).max(axis=1)
    competes = np.array([row.role in ("tuned", "paper") for row in rows])
    flagged = competes & (held is not None) & ((held_figure > tuned_high) | (held_figure < tuned_low))
    contenders = np.flatnonzero(competes)
    winner, runner = np.empty(len(cells), dtype=int), np.empty(len(cells), dtype=int)
    margin, mlow = np.empty(len(cells)), np.empty(len(cells))
    for c in cells:
        key = np.where(np.isnan(ratio[contenders, c]), np.inf, ratio[contenders, c])
        order = contenders[np.argsort(key, kind="stable")]
        winner[c], runner[c] = order[0], order[1]
        margin[c], mlow[c] = worst_margin(ys[order[0]][:, c], ys[order[1]][:, c], level)
    return ScenarioTable(
        tuning,
        tuple(rows),
        stats,
        level,
        winner,
        runner,
        margin,
        mlow,
        tuple(tuple(s) for s in seeds),
        tuned_figure,
        tuned_low,
        tuned_high,
        held_figure,
        flagged,
        held,
    )


def scenario_table(
    alpha: float = 1.0,
    *,
    m: int = M,
    w: float = W,
    scenarios: Mapping[str, tuple[str, float, Scenario]] = PRESETS,
    sampling: Sampling | None = None,
    execution: Execution | None = None,
    grids: TuningGrids = TuningGrids(),
    n_report: int | None = None,
    rate: float | None = DEFAULT_RATE,
    refine: int = 0,
) -> ScenarioTable:
    """The fair table (module docstring) for paper A's model with this α (β = w√(2α), A.25) over ``scenarios``: the
    tuning of :func:`isl_core.tune` with these arguments (cached), the held-out runs on ``n_report`` seeds after the
    tuning's (default four times as many; cached), then :func:`table_from` at ``sampling.level``.

    Parameters
    ----------
    alpha, m, w : float, int, float
        Paper A's model: α (default 1), the state dimension, the stationary std of X_m (β = w√(2α)).
    scenarios : mapping
        name → (label, σ(0), :class:`Scenario`), the table's columns and the set every knob is tuned over.
    sampling : Sampling, optional
        The tuning's seeds, horizon and burn-in as in :func:`isl_core.tune` (default
        :data:`isl_core.TUNING_SAMPLING`), and the intervals' confidence ``level`` (at least 0.5).
    execution : Execution, optional
        As in :func:`isl_core.tune`; its ``progress`` follows the tuning, the held-out runs use its threads and cache.
    grids : TuningGrids
        As in :func:`isl_core.tune`.
    n_report : int, optional
        How many held-out seeds the table is read on (:func:`!isl_core.scenario.heldout.held_out`).
    rate, refine : float or None, int
        Sensor readings per 1/r_min at σ(0) and the step's halvings, as in :func:`isl_core.tune`.

    Returns
    -------
    ScenarioTable
        Every row's period ratio per cell with its interval, the winner and runner-up per cell and their margin.

    Examples
    --------
    A small table: one scenario, two seeds, a short run and coarse grids of the knobs.

    >>> from isl_core import Execution, Sampling, TuningGrids, scenario_table
    >>> from isl_core.scenario import PRESETS
    >>> grids = TuningGrids(isl_ell=(-2.0, 0.0), memory=(100.0,), robust_c=(2.0,), imm_switch=(1e-3,), imm_modes=(6,))
    >>> table = scenario_table(1.0, scenarios={"sigma_drop": PRESETS["sigma_drop"]}, grids=grids,
    ...                        sampling=Sampling.first(2, horizon=15.0, burn=2.0),
    ...                        execution=Execution(workers=1, cache=False))
    >>> [row.name for row in table.rows][:3]
    ['clairvoyant', 'kbf', 'isl']
    """
    sampling = tuning_sampling(sampling)
    level = check_real("sampling.level", sampling.level, lo=0.5, hi=1.0, hi_open=True)
    execution = local_threads(execution)
    res = tune(
        alpha,
        m=m,
        w=w,
        presets=scenarios,
        sampling=sampling,
        execution=execution,
        grids=grids,
        rate=rate,
        refine=refine,
    )
    assert res is not None  # tune computes what is not cached (compute=True)
    report = held_out(res, n_report, execution=replace(execution, progress=None))
    return table_from(res, level, report)
