"""The scenario statistic: RMSE ratios to the clairvoyant reference over fixed periods, pooled over seeds, at the
worst coordinate.

A scenario's time is cut into a few fixed **periods** (:func:`scenario_periods`; times in units of 1/r_min at σ(0)):
for a scenario whose σ changes at t_c, the first 1/r_min after the change [t_c, t_c + 1), the first 2/r_min
[t_c, t_c + 2) and the settled rest [t_c + 2, T) (after the last change, for a drift or several steps); for a
scenario without a change, the settled run after the start [burn, T), burn = 2/r_min by default. Per filter f,
period p and coordinate i, over the S seeds s and the steps k of the period,

    ratio_f,p,i = √( Σ_s,k e_f,i(s, k)²  /  (S · Σ_k P_ii(k)) )          ratio_f,p = max_i ratio_f,p,i

— each coordinate's RMSE pooled over the seeds over the clairvoyant filter's exact variance P_ii
(:func:`isl_core.scenario.clairvoyant`), as paper A reports each coordinate, and the cell's figure is the **worst
coordinate's**: an average over the coordinates would let a filter that loses on X₁ hide it behind X₂ and X₃. The
clairvoyant filter's expected mean square is exactly S·Σ_k P_ii per coordinate (its P is exact on the grid), so each
of its coordinates' ratio² is an unbiased estimate of 1; the maximum over m of them lies above 1 by their sampling
spread (a per cent or two at 128 seeds), which the clairvoyant row shows. No maximum is taken over time windows.

**Intervals** come from the seeds, which are independent runs: each contributes y_f,p,i(s) = Σ_k e_f,i(s, k)² /
Σ_k P_ii(k), a coordinate's ratio² is their mean ȳ, and its interval is Student's ȳ ± t_{S−1}·sd(y)/√S at
``level`` under the square root (the lower end held at 0); a cell's interval is its worst coordinate's. **Per
seed**, the seed's own worst-coordinate ratio √(max_i y_f,p,i(s)) shows what the mean hides: the worst seed and
the number of seeds above 2× are reported beside each cell, and a seed on which a filter diverged (an infinite
error) makes the cell read infinite — a divergence is never averaged away.

**Margins** between two filters are paired over the seeds (the same noise). For one coordinate, the ratio of mean
squares R = ȳ_b/ȳ_a has the delta-method standard error of d(s) = y_b(s) − R·y_a(s), sd(d)/(√S·ȳ_a) (Fieller's
linearisation), and the margin √R the lower bound √(R − t·se) (:func:`paired_margin`). Between two cells' figures
(each its worst coordinate) the margin is ratio_b/ratio_a, and its lower bound that of the paired margin at the
winner's worst coordinate i_a (:func:`!worst_margin`): since ratio_b ≥ ratio_b,i_a, that is a lower bound of the
margin too — conservative. A lower bound ≤ 1 is a tie: the seeds cannot tell the two filters apart.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import cast

import numpy as np

from ..validate import check_real
from .base import Scenario
from .run import ScenarioRun, first_step

__all__ = [
    "BURN",
    "Period",
    "PeriodRatios",
    "edge_times",
    "paired_margin",
    "per_seed",
    "period_ratios",
    "ratios_from",
    "scenario_periods",
    "seed_ratios",
    "worst_from",
    "worst_margin",
]

BURN = 2.0  #: the start left out of a scenario without a change (each filter's start from its own guess), 1/r_min
AFTER = (1.0, 2.0)  #: the periods just after a change: its first 1/r_min and its first 2/r_min
SETTLE = 2.0  #: the settled period starts this long after the last change, 1/r_min


@dataclass(frozen=True)
class Period:
    """A period [``start``, ``end``) in units of 1/r_min at σ(0); ``name`` is stable (CSV/JSON keys)."""

    name: str
    label: str
    start: float
    end: float


def scenario_periods(scenario: Scenario, horizon: float, *, burn: float = BURN) -> tuple[Period, ...]:
    """The fixed periods of ``scenario`` over ``horizon`` (module docstring); those that would end after the horizon
    or start at it are left out, and a ``ValueError`` says so if none is left.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    horizon : float
        The run's length, units of 1/r_min.
    burn : float
        The start left out where σ does not change.

    Returns
    -------
    tuple of Period
        ``name``, ``label``, ``start`` and ``end`` of each.

    Examples
    --------
    >>> from isl_core import Scenario, scenario_periods
    >>> drop = Scenario(sigma_knots=((10.0, 2.0),))
    >>> [(p.name, p.start, p.end) for p in scenario_periods(drop, 30.0)]
    [('after_1', 10.0, 11.0), ('after_2', 10.0, 12.0), ('settled', 12.0, 30.0)]
    """
    horizon = check_real("horizon", horizon, lo=0.0, lo_open=True)
    burn = check_real("burn (in units of 1/r_min)", burn, lo=0.0, hi=horizon, hi_open=True)
    knots = [t for t, _ in scenario.sigma_knots if t < horizon]
    if not knots:
        out = [Period("settled", f"settled, after {burn:g}/r_min", burn, horizon)]
    else:
        out = []
        for j, t_c in enumerate(knots):
            tag = "" if len(knots) == 1 else f"_{j + 1}"
            for a in AFTER:
                if t_c + a <= horizon:
                    out.append(
                        Period(
                            f"after{tag}_{a:g}", f"first {a:g}/r_min after the change at {t_c:g}/r_min", t_c, t_c + a
                        )
                    )
        last = knots[-1]
        if last + SETTLE < horizon:
            out.append(Period("settled", f"settled, from {SETTLE:g}/r_min after the change", last + SETTLE, horizon))
    if not out:
        raise ValueError(f"horizon = {horizon:g} leaves no period: it must reach past the change of σ")
    return tuple(out)


def edge_times(periods: tuple[Period, ...], horizon: float) -> tuple[float, ...]:
    """Window edges (0, …, horizon) at every period's start and end: a plan with them sums each period exactly
    (:func:`isl_core.scenario.run.plan_scenario` ``edges``)."""
    return tuple(sorted({0.0, float(horizon), *(p.start for p in periods), *(p.end for p in periods)}))


def _windows(run: ScenarioRun, period: Period) -> np.ndarray:
    """Which of the run's windows lie within ``period`` (nw,), by the steps where its start and end fall."""
    step = run.h * run.r_min
    k0 = first_step(period.start, step, run.N)
    k1 = run.N if period.end >= run.t[-1] * run.r_min else first_step(period.end, step, run.N)
    edges = np.concatenate([[0], np.cumsum(run.steps)])
    inside = (edges[:-1] >= k0) & (edges[1:] <= k1)
    if not np.any(inside):
        raise ValueError(
            f"no window of the run lies within the period {period.label} "
            f"[{period.start:g}, {period.end:g})/r_min: plan it with edges at the periods"
        )
    return inside


def per_seed(mse: np.ndarray, run: ScenarioRun, periods: tuple[Period, ...]) -> np.ndarray:
    """y_f,p,i(s) of the module docstring, (seeds, periods, filters, m): each seed's mean square over the period per
    coordinate over the clairvoyant variance's. ``mse`` (seeds, windows, filters, m) as
    :attr:`!ScenarioAverage.mse`; inf for a filter that diverged in the period."""
    steps = run.steps.astype(float)
    out = np.empty((mse.shape[0], len(periods), mse.shape[2], mse.shape[3]))
    for p, period in enumerate(periods):
        keep = _windows(run, period)
        w = steps[keep]
        with np.errstate(invalid="ignore"):  # inf·0 cannot occur: every window has a step
            sq = np.einsum("w,swfm->sfm", w, mse[:, keep])
        ref = w @ run.ref_var[keep]
        out[:, p] = sq / ref
    return out


def seed_ratios(y: np.ndarray) -> np.ndarray:
    """Each seed's own worst-coordinate ratio √(max_i y_i(s)), from ``y`` (seeds, ..., m): (seeds, ...)."""
    return cast("np.ndarray", np.sqrt(np.max(y, axis=-1)))


def _half(y: np.ndarray, level: float, axis: int = 0) -> np.ndarray:
    """Student's half-width t_{S−1}·sd/√S of the mean of ``y`` over its seeds (``axis``); nan for one seed."""
    seeds = y.shape[axis]
    if seeds < 2:
        return np.full(np.delete(y.shape, axis), np.nan)
    from scipy.stats import t as student  # here, not at the top: the page imports this module

    with np.errstate(invalid="ignore"):
        sd = y.std(axis=axis, ddof=1)
    return cast("np.ndarray", student.ppf((1 + level) / 2, seeds - 1) * sd / math.sqrt(seeds))


#: (ratio, low, high, coordinate) of :func:`worst_from`
Worst = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def worst_from(y: np.ndarray, level: float) -> Worst:
    """(ratio, low, high, coordinate) of the worst coordinate from the seeds' contributions ``y`` (seeds, cells,
    filters, m), each (filters, cells): per cell and filter the coordinate with the largest pooled ratio, that ratio
    and its Student interval (module docstring). A diverged filter reads inf."""
    mean = y.mean(axis=0)  # (cells, filters, m)
    half = _half(y, level)
    coordinate = np.argmax(np.where(np.isnan(mean), np.inf, mean), axis=-1)
    pick: Callable[[np.ndarray], np.ndarray] = lambda a: np.take_along_axis(a, coordinate[..., None], axis=-1)[..., 0]  # noqa: E731
    m, hw = pick(mean), pick(half)
    with np.errstate(invalid="ignore"):
        low, high = np.sqrt(np.maximum(m - hw, 0.0)), np.sqrt(m + hw)
    return np.sqrt(m).T, low.T, high.T, coordinate.T


def worst_margin(ya: np.ndarray, yb: np.ndarray, level: float = 0.95) -> tuple[float, float]:
    """Filter b's worst-coordinate ratio over filter a's, and its conservative lower bound: the paired margin's at a's
    worst coordinate (module docstring). ``ya``, ``yb`` (seeds, m): each seed's contribution per coordinate."""
    ma, mb = ya.mean(axis=0), yb.mean(axis=0)
    i = int(np.argmax(np.where(np.isnan(ma), np.inf, ma)))
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        margin = float(np.sqrt(mb.max() / ma[i]))
    low = float(paired_margin(ya[:, i], yb[:, i], level)[1])
    return margin, min(low, margin) if math.isfinite(margin) else low


@dataclass(frozen=True)
class PeriodRatios:
    """The statistic of the module docstring: ``ratio[f, p]`` (the worst coordinate's, ``coordinate[f, p]``, 0-based)
    with its interval ``low``/``high`` at ``level`` per filter (``filters``, names) and period (``periods``); ``y``
    (seeds, periods, filters, m) the seeds' contributions per coordinate, kept for the per-coordinate ratios, the
    seeds' own ratios and paired margins (:meth:`margin`)."""

    filters: tuple[str, ...]
    periods: tuple[Period, ...]
    ratio: np.ndarray
    low: np.ndarray
    high: np.ndarray
    y: np.ndarray
    level: float
    coordinate: np.ndarray

    @property
    def coordinates(self) -> np.ndarray:
        """Every coordinate's ratio (filters, periods, m)."""
        return cast("np.ndarray", np.sqrt(self.y.mean(axis=0)).transpose(1, 0, 2))

    @property
    def worst_seed(self) -> np.ndarray:
        """Per filter and period, the largest of the seeds' own worst-coordinate ratios (filters, periods)."""
        return cast("np.ndarray", seed_ratios(self.y).max(axis=0).T)

    def above(self, factor: float = 2.0) -> np.ndarray:
        """Per filter and period, how many seeds' own ratio exceeds ``factor`` (filters, periods)."""
        return cast("np.ndarray", (seed_ratios(self.y) > factor).sum(axis=0).T)

    def margin(self, a: int, b: int) -> tuple[np.ndarray, np.ndarray]:
        """Per period, filter b's ratio over filter a's and its lower bound (:func:`!worst_margin`)."""
        out = np.array([worst_margin(self.y[:, p, a], self.y[:, p, b], self.level) for p in range(len(self.periods))])
        return out[:, 0], out[:, 1]


def ratios_from(y: np.ndarray, level: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ratio, low, high) from the seeds' contributions ``y`` (seeds, ...): √ȳ and √(ȳ ∓ t·sd/√S), transposed so
    that the filters come first when ``y`` is (seeds, periods, filters)."""
    mean = y.mean(axis=0)
    half = _half(y, level)
    with np.errstate(invalid="ignore"):
        low, high = np.sqrt(np.maximum(mean - half, 0.0)), np.sqrt(mean + half)
    return np.sqrt(mean).T, low.T, high.T


def period_ratios(
    mse: np.ndarray, run: ScenarioRun, periods: tuple[Period, ...], *, level: float = 0.95
) -> PeriodRatios:
    """The period statistic of every filter of ``run`` (module docstring) from every seed's windowed mean squares
    ``mse`` (seeds, windows, filters, m).

    Parameters
    ----------
    mse : numpy.ndarray
        Every seed's windowed mean squares (seeds, windows, filters, m), e.g. :attr:`!ScenarioAverage.mse`.
    run : ScenarioRun
        A run of the same plan (its windows and filters).
    periods : tuple of Period
        The periods, e.g. :func:`scenario_periods`.
    level : float, default 0.95
        Confidence level.

    Returns
    -------
    PeriodRatios
        ``ratio[f, p]`` with its interval per filter and period.

    Examples
    --------
    >>> from isl_core import Scenario, average_scenario, period_ratios, scenario_periods
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> rise = Scenario(sigma_knots=((5.0, 40.0),))
    >>> avg = average_scenario(model, model.beta, rise, seeds=range(2), horizon=10.0, windows=10)
    >>> stat = period_ratios(avg.mse, avg.run, scenario_periods(rise, 10.0, burn=1.0))
    >>> [p.name for p in stat.periods], stat.ratio.shape  # filters × periods
    (['after_1', 'after_2', 'settled'], (3, 3))
    """
    level = check_real("level", level, lo=0.5, hi=1.0, hi_open=True)
    y = per_seed(mse, run, periods)
    ratio, low, high, coordinate = worst_from(y, level)
    return PeriodRatios(run.names, tuple(periods), ratio, low, high, y, level, coordinate)


def paired_margin(ya: np.ndarray, yb: np.ndarray, level: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Filter b's ratio over filter a's, √(ȳ_b/ȳ_a), and its lower bound at two-sided ``level`` from the seeds
    (axis 0) paired (module docstring: the delta method for a ratio of means). inf/nan where a filter diverged.

    Parameters
    ----------
    ya, yb : numpy.ndarray
        Filters a's and b's mean squared errors, one row per seed.
    level : float, default 0.95
        Two-sided confidence level.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        The ratio √(ȳ_b/ȳ_a) and its lower bound.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import paired_margin
    >>> ya = np.array([[1.0], [1.2], [0.9]])  # mean squared errors per seed (rows) of filter a
    >>> ratio, low = paired_margin(ya, 4.0 * ya)  # filter b: twice the RMSE on every seed
    >>> ratio.tolist(), low.tolist()
    ([2.0], [2.0])
    """
    ma, mb = ya.mean(axis=0), yb.mean(axis=0)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        r = mb / ma
        half = _half(yb - r * ya, level) / ma
        return np.sqrt(r), np.sqrt(np.maximum(r - half, 0.0))
