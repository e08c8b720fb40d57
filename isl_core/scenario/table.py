"""Who wins where, in a fair contest: every family at its minimax tuning, on the period statistic, per scenario.

:func:`scenario_table` takes the tuning of :func:`isl_core.tune` (one run per preset and seed with every
variant of every family on the same noise; cached) and reports, per row and cell (preset × period of
:func:`isl_core.scenario.periods.scenario_periods`), the period statistic — the normalized RMSE over the coordinates,
pooled over the seeds, over the clairvoyant filter's exact variance — with Student's interval over the seeds:

* **references** — the clairvoyant filter (knows σ(t); reads 1 up to sampling error: the check of the denominator)
  and the Kalman–Bucy filter optimal for σ(0) (knows σ at the start, learns nothing);
* **tuned** — each family of :data:`isl_core.scenario.tuning.FAMILIES` (none knows σ(t)) at its minimax knob, the one
  tuning rule: the least, over the knob's grid, of the largest ratio over every cell of the table;
* **paper** — paper A's ISL filter at table (A.31)'s ν, the paper's own value (where the table has this α);
* **oracle-tuned** — each family at the best knob *per preset* (a reference: the tuning one would pick knowing the
  scenario; its knob is given per preset).

Every row says its tuning and its origin. Each tuned row *is* its variant's column of the tuning run, so it sits
at its tuning curve's minimax point. A preset's number is a row's largest ratio over the preset's periods; the
winner of a cell is the lowest of the tuned and paper rows, with the paired margin over the runner-up
(:func:`isl_core.scenario.periods.paired_margin`) — a tie where its lower bound is ≤ 1.
Times are in units of 1/r_min of the model at σ(0).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from ..paper import M, W
from ..validate import check_real
from .base import Scenario
from .periods import paired_margin
from .presets import PRESETS
from .tuning import FAMILIES, Tuning, TuningGrids, tune

__all__ = ["PRESETS", "ScenarioTable", "TableRow", "knob_text", "scenario_table", "table_from"]


@dataclass(frozen=True)
class TableRow:
    """One row: ``name`` (stable: the family, or ``oracle:<family>``), ``label``, ``role`` ("reference", "tuned",
    "paper", "oracle"), what it ``knows`` of σ, its ``tuning`` (knob → value; per preset for an oracle row), its
    ``origin`` and ``columns``, per preset the index of its filter in the tuning's run."""

    name: str
    label: str
    role: str
    knows: str
    tuning: dict | tuple[dict, ...]
    origin: str
    columns: tuple[int, ...]


@dataclass(frozen=True)
class ScenarioTable:
    """``ratio[r, c]`` with ``low``/``high`` at ``level`` per row (``rows``) and cell (``tuning.cells``: preset
    index, period); :meth:`preset` the largest over a preset's cells; per cell ``winner``/``runner_up`` (row
    indices among the tuned and paper rows), ``margin`` (the runner-up's ratio over the winner's, paired over the
    seeds) and ``margin_low`` its lower bound; ``tie`` where that bound is ≤ 1."""

    tuning: Tuning
    rows: tuple[TableRow, ...]
    ratio: np.ndarray
    low: np.ndarray
    high: np.ndarray
    level: float
    winner: np.ndarray
    runner_up: np.ndarray
    margin: np.ndarray
    margin_low: np.ndarray

    @property
    def tie(self) -> np.ndarray:
        return self.margin_low <= 1.0

    def preset(self, p: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per row, the largest ratio over preset ``p``'s periods and the largest ends of their intervals."""
        cells = self.tuning.preset_cells(p)
        return (self.ratio[:, cells].max(axis=1), self.low[:, cells].max(axis=1), self.high[:, cells].max(axis=1))


KNOB_TEXT = {
    "ell": lambda v: f"ν/β = 2^{v:g} = {2.0**v:.3g}",
    "memory": lambda v: f"W = {v:g} readings",
    "c": lambda v: f"c = {v:g}",
    "switch": lambda v: f"switch {v:g} a reading",
    "modes": lambda v: f"{v:g} modes",
}


def knob_text(knob: Mapping) -> str:
    """A knob in words: ``ν/β = 2^-2 = 0.25``, ``W = 30 readings``, ``c = 2, W = 10 readings``."""
    return ", ".join(KNOB_TEXT[k](v) if k in KNOB_TEXT else f"{k} = {v}" for k, v in knob.items())


def _rows(tuning: Tuning) -> list[TableRow]:
    npre = len(tuning.presets)
    rows = [
        TableRow(
            "clairvoyant",
            "Kalman filter that knows σ(t) (clairvoyant)",
            "reference",
            "σ(t)",
            {},
            "the reference: its exact covariance P is every ratio's denominator",
            (0,) * npre,
        ),
        TableRow(
            "kbf",
            "Kalman–Bucy for constant σ = σ(0)",
            "reference",
            "σ(0)",
            {},
            "the stationary filter of σ(0) (A.21–A.23)",
            (1,) * npre,
        ),
    ]
    for fam, (label, _) in FAMILIES.items():
        j = tuning.minimax(fam)
        rows.append(
            TableRow(
                fam,
                f"{label}, {knob_text(tuning.knobs[j])}",
                "tuned",
                "nothing of σ",
                dict(tuning.knobs[j]),
                tuning.origin,
                (j,) * npre,
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
                "the least largest ratio over each preset's periods, on the same runs",
                cols,
            )
        )
    return rows


def table_from(tuning: Tuning, level: float = 0.95) -> ScenarioTable:
    """The fair table (module docstring) of a :class:`isl_core.scenario.tuning.Tuning`.

    Parameters
    ----------
    tuning : Tuning
        The result of :func:`isl_core.tune`.
    level : float, default 0.95
        Confidence level of the intervals.

    Returns
    -------
    ScenarioTable
        As :func:`scenario_table`.

    Examples
    --------
    >>> from isl_core import TuningGrids, table_from, tune
    >>> from isl_core.scenario import PRESETS
    >>> grids = TuningGrids(isl_ell=(-2.0, 0.0), memory=(100.0,), robust_c=(2.0,), imm_switch=(1e-3,), imm_modes=(6,))
    >>> tuning = tune(1.0, presets={"sigma_drop": PRESETS["sigma_drop"]}, seeds=2, horizon=15.0, grids=grids,
    ...               cache=False, workers=1)
    >>> table_from(tuning, level=0.9).level
    0.9
    """
    level = check_real("level", level, lo=0.5, hi=1.0, hi_open=True)
    rows = _rows(tuning)
    r, lo, hi = tuning.stats(level)
    cells = range(len(tuning.cells))
    col = np.array([[row.columns[tuning.cells[c][0]] for c in cells] for row in rows])  # (rows, cells)
    pick = np.take_along_axis
    ratio, low, high = (pick(a, col, axis=0) for a in (r, lo, hi))
    contenders = np.array([i for i, row in enumerate(rows) if row.role in ("tuned", "paper")])
    winner, runner, margin, mlow = (
        np.empty(len(cells), dtype=int),
        np.empty(len(cells), dtype=int),
        np.empty(len(cells)),
        np.empty(len(cells)),
    )
    for c in cells:
        order = contenders[
            np.argsort(np.where(np.isnan(ratio[contenders, c]), np.inf, ratio[contenders, c]), kind="stable")
        ]
        winner[c], runner[c] = order[0], order[1]
        ya, yb = tuning.y[:, c, col[order[0], c]], tuning.y[:, c, col[order[1], c]]
        margin[c], mlow[c] = paired_margin(ya, yb, level)
    return ScenarioTable(tuning, tuple(rows), ratio, low, high, level, winner, runner, margin, mlow)


def scenario_table(
    alpha: float = 1.0,
    *,
    m: int = M,
    w: float = W,
    scenarios: Mapping[str, tuple[str, float, Scenario]] = PRESETS,
    seeds: int = 32,
    horizon: float = 30.0,
    burn: float = 2.0,
    level: float = 0.95,
    grids: TuningGrids = TuningGrids(),
    workers: int | None = None,
    progress: Callable[[float], None] | None = None,
    cache: bool = True,
) -> ScenarioTable:
    """The fair table (module docstring) for paper A's model with this α (β = w√(2α), A.25) over ``scenarios``: the
    tuning of :func:`isl_core.tune` with these arguments (cached), then :func:`table_from` at
    ``level``.

    Parameters
    ----------
    alpha, m, w : float, int, float
        Paper A's model: α (default 1), the state dimension, the stationary std of X_m (β = w√(2α)).
    scenarios : mapping
        name → (label, σ(0), :class:`Scenario`), the table's columns and the set every knob is tuned over.
    seeds, horizon, burn : int, float, float
        Independent noises, run length and the start left out (units of 1/r_min).
    level : float, default 0.95
        Confidence level of the intervals.
    grids, workers, progress, cache : TuningGrids, int, callable, bool
        As in :func:`isl_core.tune`.

    Returns
    -------
    ScenarioTable
        Every row's period ratio per cell with its interval, the winner and runner-up per cell and their margin.

    Examples
    --------
    A small table: one scenario, two seeds, a short run and coarse grids of the knobs.

    >>> from isl_core import TuningGrids, scenario_table
    >>> from isl_core.scenario import PRESETS
    >>> grids = TuningGrids(isl_ell=(-2.0, 0.0), memory=(100.0,), robust_c=(2.0,), imm_switch=(1e-3,), imm_modes=(6,))
    >>> table = scenario_table(1.0, scenarios={"sigma_drop": PRESETS["sigma_drop"]}, seeds=2, horizon=15.0,
    ...                        grids=grids, cache=False, workers=1)
    >>> [row.name for row in table.rows][:3]
    ['clairvoyant', 'kbf', 'isl']
    """
    level = check_real("level", level, lo=0.5, hi=1.0, hi_open=True)
    res = tune(
        alpha,
        m=m,
        w=w,
        presets=scenarios,
        seeds=seeds,
        horizon=horizon,
        burn=burn,
        grids=grids,
        workers=workers,
        progress=progress,
        cache=cache,
    )
    assert res is not None  # tune computes what is not cached (compute=True)
    return table_from(res, level)
