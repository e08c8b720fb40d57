"""Who wins where, as maps over a scenario's parameter: the filter with the lowest ratio to the clairvoyant one.

:func:`who_wins_map` sweeps one parameter of a scenario (paper A's model with this α, the filters of
:mod:`isl_core.scenario_table`, ``seeds`` independent noises per cell) and reports, per cell, every filter's ratio
to the clairvoyant Kalman filter — √(mean over seeds of the mean squared error / the mean clairvoyant variance),
the largest over the coordinates — the filter with the lowest one (the clairvoyant filter aside) and its margin,
the runner-up's ratio over the winner's, and whether the cell is a tie (the margin's paired-bootstrap lower 95 %
bound over the seeds is ≤ 1):

* ``"sigma_step"`` — σ(0) = 20 steps to 20·r at 10/r_min, for each ratio r of ``values`` (default 0.1 … 10): a
  two-dimensional map, ratio r × time since the step (windows of ``window``/r_min, the rows);
* ``"tails"`` — Student-t observation noise with d degrees of freedom, for each d of ``values`` (default 2.5 … 100),
  σ = 20: the worst case over the windows after ``burn`` (one row);
* ``"sensor"`` — a sensor read every Δ/r_min, for each Δ of ``values`` (default 0 … 0.5), σ = 20: likewise.

Times are in units of 1/r_min of the model at σ(0) = 20. Any model with α > 0 is paper A's for one w: β = w√(2α)
(A.25), so a model given by its β is mapped with w = β/√(2α).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .model import Model
from .paper import M, W
from .scenario import Scenario
from .scenario_average import BOOT_SEED, average_scenario, margin_low, resampled
from .scenario_table import _filters, table_labels
from .validate import check_int, check_real, check_reals

__all__ = ["MAPS", "WhoWinsMap", "who_wins_map"]

SIGMA0 = 20.0
STEP_AT = 10.0  #: the σ step's time, 1/r_min
MAPS = {
    "sigma_step": (0.1, 0.2, 0.5, 2.0, 5.0, 10.0),
    "tails": (2.5, 3.0, 4.0, 6.0, 10.0, 30.0, 100.0),
    "sensor": (0.0, 0.02, 0.05, 0.1, 0.2, 0.5),
}
AXIS_LABELS = {"sigma_step": "σ after / σ before", "tails": "degrees of freedom d",
               "sensor": "sensor interval Δ (1/r_min)"}


@dataclass(frozen=True)
class WhoWinsMap:
    """``ratio[row, col, f]`` per cell and filter; ``x`` the swept values (columns); ``rows`` the times since the
    step (window starts, 1/r_min) for ``"sigma_step"``, else one row (nan); ``winner[row, col]`` the index in
    ``filters`` of the lowest ratio but the clairvoyant filter's, ``margin`` the runner-up's ratio over it, and
    ``margin_low`` the margin's lower 95 % bound (seeds resampled together for every filter: a paired bootstrap); a
    cell whose ``margin_low`` is ≤ 1 is a ``tie`` — the seeds cannot tell the winner from the runner-up."""

    kind: str
    alpha: float
    x: np.ndarray
    rows: np.ndarray
    filters: tuple[str, ...]
    labels: tuple[str, ...]
    ratio: np.ndarray
    seeds: int
    window: float
    margin_low: np.ndarray
    model: Model | None = None  #: the model at σ(0) (paper A's with this α, w and m)

    @property
    def tie(self) -> np.ndarray:
        return self.margin_low <= 1.0

    @property
    def winner(self) -> np.ndarray:
        return 1 + np.argmin(self.ratio[:, :, 1:], axis=2)

    @property
    def margin(self) -> np.ndarray:
        ranked = np.sort(self.ratio[:, :, 1:], axis=2)
        return ranked[:, :, 1] / ranked[:, :, 0]


def _scenario(kind: str, value: float) -> Scenario:
    if kind == "sigma_step":
        return Scenario(sigma_knots=((STEP_AT, SIGMA0 * value),))
    if kind == "tails":
        return Scenario(noise="student", dof=value)
    return Scenario(sensor_interval=value)


def who_wins_map(
    kind: str,
    alpha: float = 1.0,
    *,
    values: Sequence[float] | None = None,
    m: int = M,
    w: float = W,
    seeds: int = 32,
    window: float = 1.0,
    after: float = 10.0,
    burn: float = 2.0,
    progress: Callable[[float], None] | None = None,
) -> WhoWinsMap:
    """The map of ``kind`` (module docstring); ``after``: how long after the σ step (or, for the other maps, the
    whole run after ``burn``) is simulated, in units of 1/r_min."""
    if kind not in MAPS:
        raise ValueError(f"kind must be one of {', '.join(MAPS)}; got {kind!r}")
    alpha = check_real("alpha", alpha, lo=0.0, lo_open=True)
    lo = {"sigma_step": 0.01, "tails": 2.0, "sensor": 0.0}[kind]
    values = check_reals("values", MAPS[kind] if values is None else values, lo=lo, lo_open=kind != "sensor",
                         hi={"sigma_step": 100.0, "tails": 1e6, "sensor": 10.0}[kind])
    seeds = check_int("seeds", seeds, lo=2, hi=10_000)
    window = check_real("window", window, lo=0.0, lo_open=True, hi=100.0)
    after = check_real("after", after, lo=window, hi=1e4)
    burn = check_real("burn", burn, lo=0.0, hi=after, hi_open=True)
    model = Model.from_w(alpha, w, SIGMA0, m)
    nu, nu_label, extra = _filters(model, alpha, m, w)
    start = STEP_AT if kind == "sigma_step" else burn
    horizon = (STEP_AT if kind == "sigma_step" else 0.0) + after
    windows = max(1, round(horizon / window))
    first = min(round(start / (horizon / windows)), windows - 1)  # the first window counted (by index: every run
    rows = np.arange(first, windows) * (horizon / windows) - STEP_AT  # has the same windows, up to a few steps)
    cells, lows, names, labels = [], [], None, None
    rng = np.random.default_rng(BOOT_SEED)
    for c, value in enumerate(values):
        avg = average_scenario(model, nu, _scenario(kind, value), seeds=range(seeds), horizon=horizon,
                               windows=windows, extra=extra, progress=progress, done=c * seeds,
                               total=len(values) * seeds)
        mse, run = avg.mse, avg.run
        names, labels = run.names, table_labels(run, nu_label)
        ref = run.ref_var[first:][:, None, :]

        def cell(sample: np.ndarray, ref=ref) -> np.ndarray:  # (rows, filters)
            ratio = np.sqrt(sample.mean(axis=0)[first:] / ref).max(axis=2)
            return ratio if kind == "sigma_step" else ratio.max(axis=0)[None, :]

        point, boot = resampled(cell, mse, rng)
        cells.append(point)
        lows.append(margin_low(point, boot))
    if kind != "sigma_step":
        rows = np.array([math.nan])
    return WhoWinsMap(kind, alpha, np.array(values, dtype=float), rows, names, labels,
                      np.stack(cells, axis=1), seeds, window, np.stack(lows, axis=1), model)
