"""Who wins where, as maps over a scenario's parameter: the filter with the lowest ratio to the clairvoyant one.

:func:`who_wins_map` sweeps one parameter of a scenario (paper A's model with this α, σ(0) = 20, ``n_seeds``
independent noises per cell) with the table's filters (:mod:`isl_core.scenario.table`): the clairvoyant reference,
the Kalman–Bucy filter for σ(0) and every family of :data:`isl_core.FAMILIES` at its tuned knob — the
``tuning`` given, else the one cached for (α, m, w) at the table's defaults, else the shipped one nearest them
(:mod:`isl_core.scenario.shipped`), else (said in each label and in ``origin``) the constructors' defaults. Per
cell it reports every filter's period statistic (:mod:`isl_core.scenario.periods`: the worst coordinate's RMSE,
pooled over the seeds, over the clairvoyant variance; with a tuning, on the seeds after the tuning's: held out), the
filter with the lowest one (the clairvoyant filter aside) and its margin over the runner-up, paired over the seeds,
with a tie where the margin's lower 95 % bound is ≤ 1:

* ``"sigma_step"`` — σ(0) = 20 steps to 20·r at 10/r_min, for each ratio r of ``values`` (default 0.025 … 100:
  σ from 0.5 to 2000, beyond the ranges the learners assume): a
  two-dimensional map, ratio r × time since the step (periods of ``window``/r_min, the rows);
* ``"tails"`` — Student-t observation noise with d degrees of freedom, for each d of ``values`` (default 2.5 … 100),
  σ = 20: the settled period after ``burn`` (one row);
* ``"sensor"`` — a sensor read every Δ/r_min, for each Δ of ``values`` (default 0 … 0.5), σ = 20: likewise.

Every cell is read at the tuning's reading rate R (:ref:`reading-rate`; without a tuning the table's default, 100
readings per 1/r_min): a sensor interval Δ below 1/R reads every 1/R. Times are in units of 1/r_min of the model at
σ(0) = 20. Any model with α > 0 is paper A's for one w: β = w√(2α)
(A.25), so a model given by its β is mapped with w = β/√(2α).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import cast

import numpy as np

from ..filters.adaptive import adaptive_kbf
from ..filters.base import SIGMA_RANGE, FilterSpec
from ..filters.imm import imm_kbf
from ..filters.isl import model_aware_isl
from ..filters.robust import robust_kbf
from ..filters.variational import variational_kbf
from ..model import Model
from ..paper import M, W
from ..validate import check_int, check_real, check_reals
from .average import average_scenario
from .base import Scenario
from .minimax import Tuning
from .periods import Period, edge_times, per_seed, worst_from, worst_margin
from .presets import DEFAULT_RATE, read_at
from .shipped import ShippedTuning, shipped_tuning
from .tuning import tune
from .variants import paper_nu

__all__ = ["MAPS", "WhoWinsMap", "map_filters", "who_wins_map"]

SIGMA0 = 20.0
STEP_AT = 10.0  #: the σ step's time, 1/r_min
MAPS = {
    "sigma_step": (0.025, 0.1, 0.2, 0.5, 2.0, 5.0, 10.0, 100.0),  # to 0.5 and 2000: beyond every assumed range
    "tails": (2.5, 3.0, 4.0, 6.0, 10.0, 30.0, 100.0),
    "sensor": (0.0, 0.02, 0.05, 0.1, 0.2, 0.5),
}
AXIS_LABELS = {
    "sigma_step": "σ after / σ before",
    "tails": "degrees of freedom d",
    "sensor": "sensor interval Δ (1/r_min)",
}


@dataclass(frozen=True)
class WhoWinsMap:
    """``ratio[row, col, f]`` per cell and filter; ``x`` the swept values (columns); ``rows`` the times since the
    step (period starts, 1/r_min) for ``"sigma_step"``, else one row (nan); ``winner[row, col]`` the index in
    ``filters`` of the lowest ratio but the clairvoyant filter's, ``margin`` the runner-up's ratio over it, and
    ``margin_low`` the margin's lower 95 % bound (paired over the seeds,
    :func:`isl_core.paired_margin`); a cell whose ``margin_low`` is ≤ 1 is a ``tie`` — the seeds cannot
    tell the winner from the runner-up.
    ``origin``: where the filters' knobs came from."""

    kind: str
    alpha: float
    x: np.ndarray
    rows: np.ndarray
    filters: tuple[str, ...]
    labels: tuple[str, ...]
    ratio: np.ndarray
    seeds: tuple[int, ...]  #: the seeds pooled in every cell
    window: float
    margin_low: np.ndarray
    model: Model  #: the model at σ(0) (paper A's with this α, w and m)
    origin: str = ""

    @property
    def tie(self) -> np.ndarray:
        return self.margin_low <= 1.0

    @property
    def winner(self) -> np.ndarray:
        return cast("np.ndarray", 1 + np.argmin(self.ratio[:, :, 1:], axis=2))

    @property
    def margin(self) -> np.ndarray:
        ranked = np.sort(self.ratio[:, :, 1:], axis=2)
        return cast("np.ndarray", ranked[:, :, 1] / ranked[:, :, 0])


def _scenario(kind: str, value: float) -> Scenario:
    if kind == "sigma_step":
        return Scenario(sigma_knots=((STEP_AT, SIGMA0 * value),))
    if kind == "tails":
        return Scenario(noise="student", dof=value)
    return Scenario(sensor_interval=value)


def map_filters(
    model: Model, alpha: float, m: int, w: float, tuning: Tuning | None, untuned: bool = False
) -> tuple[float, str, list[FilterSpec], str, int]:
    """(ν, the ISL filter's label, the other families' filters, origin, first seed) for a map: every family at the
    knob of ``tuning`` (else the cached one for α, m, w at the table's defaults, else the shipped one nearest them;
    else, or with ``untuned``, the constructors' defaults, said). With a tuning the map's seeds start after the
    tuning's: held out."""
    found: Tuning | ShippedTuning | None = tuning
    if found is None and not untuned:
        found = tune(alpha, m=m, w=w, compute=False) or shipped_tuning(alpha, m, w)
    if found is not None:
        specs = found.tuned_filters(model)
        nu = model.beta * 2.0 ** found.knobs[found.minimax("isl")]["ell"]
        first = max(found.seeds) + 1
        return nu, specs[0].label, specs[1:], f"tuned: {found.origin}; the map's seeds from {first} on", first
    nu, label = paper_nu(model, alpha, m, w)
    guess = math.sqrt(SIGMA_RANGE[0] * SIGMA_RANGE[1])
    extra = [
        model_aware_isl(model, nu),
        adaptive_kbf(model, sigma_range=SIGMA_RANGE, sigma_init=guess),
        variational_kbf(model, sigma_init=guess),
        robust_kbf(model, sigma_range=SIGMA_RANGE, sigma_init=guess),
        imm_kbf(model),
    ]
    origin = (
        f"untuned: the constructors' defaults (ISL ν of table (A.31) or β) — no tuning is cached for α = "
        f"{alpha:g}, m = {m}, w = {w:g} (isl scenario --tune computes it)"
    )
    return nu, label, [replace(e, label=f"{e.label} (untuned)") for e in extra], origin, 0


def _periods(kind: str, window: float, after: float, burn: float) -> tuple[tuple[Period, ...], float]:
    """The map's rows as periods, and the horizon."""
    if kind == "sigma_step":
        n = max(1, math.floor(after / window + 1e-9))
        return tuple(
            Period(
                f"since_{r}", f"{r * window:g}/r_min after the step", STEP_AT + r * window, STEP_AT + (r + 1) * window
            )
            for r in range(n)
        ), STEP_AT + after
    return (Period("settled", f"settled, after {burn:g}/r_min", burn, after),), after


def who_wins_map(
    kind: str,
    alpha: float = 1.0,
    *,
    values: Sequence[float] | None = None,
    m: int = M,
    w: float = W,
    n_seeds: int = 32,
    window: float = 1.0,
    after: float = 10.0,
    burn: float = 2.0,
    tuning: Tuning | None = None,
    untuned: bool = False,
    progress: Callable[[float], None] | None = None,
) -> WhoWinsMap:
    """The map of ``kind`` (module docstring).

    Parameters
    ----------
    kind : {"sigma_step", "tails", "sensor"}
        What the map sweeps (:data:`!MAPS`).
    alpha, m, w : float, int, float
        Paper A's model at σ(0) = 20: α (default 1), the state dimension, the stationary std of X_m (β = w√(2α)).
    values : sequence of float, optional
        The swept values (default the kind's).
    n_seeds : int, default 32
        How many independent noises are pooled per cell: seeds 0 … ``n_seeds`` − 1, or, with a tuning, the
        ``n_seeds`` seeds after the tuning's (held out).
    window, after, burn : float
        The σ-step map's rows; how long after the σ step (the other maps: the whole run after ``burn``) is
        simulated; the start left out (units of 1/r_min).
    tuning : Tuning, optional
        The families' knobs (default: the table's cached tuning for α, m, w, else the constructors' defaults).
    untuned : bool, default False
        The filters at their constructors' defaults instead.
    progress : callable, optional
        Called with the fraction done.

    Returns
    -------
    WhoWinsMap
        ``ratio`` (rows, values, filters), the winner per cell and the margin's lower bound.

    Examples
    --------
    >>> from isl_core import who_wins_map
    >>> tails = who_wins_map("tails", 1.0, values=[3.0, 30.0], n_seeds=2, untuned=True, after=5.0, burn=1.0)
    >>> tails.ratio.shape, tails.filters[:3]  # rows × values × filters
    ((1, 2, 8), ('clairvoyant', 'kbf', 'isl'))
    """
    if kind not in MAPS:
        raise ValueError(f"kind must be one of {', '.join(MAPS)}; got {kind!r}")
    alpha = check_real("alpha", alpha, lo=0.0, lo_open=True)
    lo = {"sigma_step": 0.01, "tails": 2.0, "sensor": 0.0}[kind]
    grid = check_reals(
        "values",
        MAPS[kind] if values is None else values,
        lo=lo,
        lo_open=kind != "sensor",
        hi={"sigma_step": 100.0, "tails": 1e6, "sensor": 10.0}[kind],
    )
    n_seeds = check_int("n_seeds", n_seeds, lo=2, hi=10_000)
    window = check_real("window", window, lo=0.0, lo_open=True, hi=100.0)
    after = check_real("after", after, lo=window, hi=1e4)
    burn = check_real("burn", burn, lo=0.0, hi=after, hi_open=True)
    model = Model.from_w(alpha, w, SIGMA0, m)
    nu, nu_label, extra, origin, first = map_filters(model, alpha, m, w, tuning, untuned)
    seeds = tuple(range(first, first + n_seeds))
    rate = tuning.rate if tuning is not None else DEFAULT_RATE  # read as the tuning read (the cached one: the default)
    periods, horizon = _periods(kind, window, after, burn)
    cells, lows = [], []
    names: tuple[str, ...] = ()
    labels: tuple[str, ...] = ()
    for c, value in enumerate(grid):
        avg = average_scenario(
            model,
            nu,
            read_at(_scenario(kind, value), rate),
            seeds=seeds,
            horizon=horizon,
            extra=extra,
            edges=edge_times(periods, horizon),
            progress=progress,
            done=c * n_seeds,
            total=len(grid) * n_seeds,
        )
        names = avg.run.names
        labels = (avg.run.labels[0], "Kalman–Bucy for constant σ = σ(0)", nu_label, *avg.run.labels[3:])
        y = per_seed(avg.mse, avg.run, periods)  # (seeds, rows, filters, m)
        ratio = worst_from(y, 0.95)[0].T  # (rows, filters): each at its worst coordinate
        ranked = 1 + np.argsort(np.where(np.isnan(ratio[:, 1:]), np.inf, ratio[:, 1:]), axis=1, kind="stable")
        low = [worst_margin(y[:, r, ranked[r, 0]], y[:, r, ranked[r, 1]])[1] for r in range(len(periods))]
        cells.append(ratio)
        lows.append(np.array(low))
    rows = np.array([p.start - STEP_AT for p in periods]) if kind == "sigma_step" else np.array([math.nan])
    return WhoWinsMap(
        kind,
        alpha,
        np.array(grid, dtype=float),
        rows,
        names,
        labels,
        np.stack(cells, axis=1),
        seeds,
        window,
        np.stack(lows, axis=1),
        model,
        origin,
    )
