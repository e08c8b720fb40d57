"""A scenario run repeated over seeds, in time: rolling RMSE ratios to the clairvoyant reference, with intervals.

:func:`average_scenario` runs :func:`isl_core.simulate_scenario` once per seed (the same grid and the
same clairvoyant variance in every run: only the noise differs) and keeps each run's windowed squared errors and
σ̂. :meth:`ScenarioAverage.rolling` gives the time-resolved picture, for a window of ``width``/r_min sliding over the
runs' short windows (:ref:`rolling-ratio`):

    ratio_f,i(t) = √( mean over seeds of the window's mean e_f,i² / the window's mean clairvoyant P_ii )

at the window's centre t, with a 95 % interval from the seeds' spread (the mean over S independent runs of the
window's mean square, ± z·s/√S, under the square root: the central limit theorem over seeds; no interval from a
single seed). The worst coordinate i is shown per window and filter (the interval is that coordinate's). **Biased
upwards**: a maximum over noisy coordinates lies above their mean, so even the clairvoyant filter's curve runs above
1 (by its coordinates' sampling spread, a few per cent with 32 seeds and windows of 1/r_min); it is a picture of
where in time a filter loses, and :meth:`ScenarioAverage.periods` is the statistic that reads 1 for the reference.

:func:`!worst_ratio` is the dashboard picture's summary: the largest ratio over windows
and coordinates, with the basic bootstrap interval over seeds — biased above 1 for the reference (1.10–1.35 at 32–64
seeds) and its interval can exclude its own estimate; the table and the maps now use the period statistic
(:mod:`isl_core.scenario.periods`). :func:`margin_low` says whether the lowest of them is told apart from the next one.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from statistics import NormalDist
from typing import TYPE_CHECKING, cast

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from ..filters.base import FilterSpec
from ..model import Model
from ..validate import check_int, check_real
from .base import Scenario
from .run import ScenarioRun, plan_scenario

if TYPE_CHECKING:
    from .periods import Period, PeriodRatios

__all__ = ["Rolling", "ScenarioAverage", "average_scenario", "margin_low", "resampled", "worst_ratio"]

BOOTSTRAP = 400  #: resamples of the basic bootstrap interval of :func:`!worst_ratio`
BOOT_SEED = 20261202  #: the bootstrap's resampling seed (tables, maps and worst cases are reproducible)


def resampled(
    statistic: Callable[[np.ndarray], np.ndarray], mse: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """``statistic(mse)`` and its :data:`BOOTSTRAP` resamples (stacked on a new first axis): each resample draws
    the seeds (``mse``'s first axis) with replacement, the same seeds for every filter."""
    seeds = mse.shape[0]
    return statistic(mse), np.array([statistic(mse[rng.integers(seeds, size=seeds)]) for _ in range(BOOTSTRAP)])


def margin_low(point: np.ndarray, boot: np.ndarray, level: float = 0.95) -> np.ndarray:
    """Per cell, the lower bound at two-sided ``level`` of the runner-up's statistic over the winner's: ``point``
    (..., filters) ranks them (the lowest wins; filter 0, the clairvoyant reference, is left out) and ``boot``
    (resamples, ..., filters), from :func:`resampled`, gives the ratio's spread. The seeds are drawn together for
    every filter (a paired bootstrap), so what the filters share — the same noise — cancels in the ratio. A bound
    ≤ 1 means the seeds cannot tell the winner from the runner-up: a tie."""
    ranked = np.argsort(point[..., 1:], axis=-1)[..., :2] + 1
    pair = np.take_along_axis(boot, np.broadcast_to(ranked, (*boot.shape[:-1], 2)), axis=-1)
    return cast("np.ndarray", np.quantile(pair[..., 1] / pair[..., 0], (1 - level) / 2, axis=0))


def worst_ratio(
    mse: np.ndarray, ref: np.ndarray, level: float, rng: np.random.Generator, *, margin: bool = False
) -> tuple[np.ndarray, ...]:
    """Per filter: max over windows and coordinates of √(mean over seeds of ``mse`` / ``ref``), and its basic
    bootstrap interval over the seeds at ``level``. ``mse`` (seeds, windows, filters, m); ``ref`` (windows, m).
    With ``margin``, also :func:`margin_low` of the lowest worst case but the reference's, from the same resamples."""
    ref = ref[:, None, :]

    def statistic(sample: np.ndarray) -> np.ndarray:
        return cast("np.ndarray", np.sqrt(sample.mean(axis=0) / ref).max(axis=(0, 2)))

    point, boot = resampled(statistic, mse, rng)
    low = 2.0 * point - np.quantile(boot, (1 + level) / 2, axis=0)
    high = 2.0 * point - np.quantile(boot, (1 - level) / 2, axis=0)
    return (point, low, high, margin_low(point, boot, level)) if margin else (point, low, high)


@dataclass(frozen=True)
class Rolling:
    """The rolling ratio (module docstring): ``t`` (n,) window centres in units of 1/r_min at σ(0); ``ratio``,
    ``low``, ``high`` (n, filters) at the worst coordinate ``coordinate`` (n, filters; 0-based); ``sigma`` (n,) the
    window's mean σ; ``sigma_hat`` (n, σ-learning filters) their mean σ̂ over seeds; ``width`` in 1/r_min."""

    t: np.ndarray
    ratio: np.ndarray
    low: np.ndarray
    high: np.ndarray
    coordinate: np.ndarray
    sigma: np.ndarray
    sigma_hat: np.ndarray
    width: float


@dataclass(frozen=True)
class ScenarioAverage:
    """Runs of one scenario with seeds ``seeds``: ``run`` is the first (grid, filters, clairvoyant variance, σ);
    ``mse`` (seeds, windows, filters, m) and ``sigma_hat`` (seeds, windows, σ-learning filters) hold every run's."""

    run: ScenarioRun
    seeds: tuple[int, ...]
    mse: np.ndarray
    sigma_hat: np.ndarray

    @property
    def learning(self) -> tuple[str, ...]:
        """Names of the filters whose σ̂ is in ``sigma_hat``, in its column order."""
        return self.run.learning

    def _slide(self, a: np.ndarray, axis: int, k: int) -> np.ndarray:
        """Step-weighted sums of ``a`` over ``k`` consecutive short windows along ``axis`` (its window axis); an
        infinite error stays infinite (summed directly, not as differences of running sums)."""
        shape = [1] * a.ndim
        shape[axis] = -1
        weighted = a * self.run.steps.astype(float).reshape(shape)
        return cast("np.ndarray", sliding_window_view(weighted, k, axis=axis).sum(axis=-1))

    def _span(self, width: float) -> tuple[int, np.ndarray]:
        """Short windows per sliding window of ``width``/r_min, and each sliding window's steps."""
        run = self.run
        short = run.t[-1] * run.r_min / len(run.steps)  # one short window, 1/r_min
        k = min(len(run.steps), max(1, round(width / short)))
        return k, sliding_window_view(run.steps.astype(float), k).sum(axis=-1)

    def _pooled(self, width: float) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
        """k, each sliding window's steps, and per sliding window every seed's mean squared error (S, n, f, m) and the
        clairvoyant variance (n, m), pooled over its k short windows by steps."""
        k, total = self._span(width)
        mse = self._slide(self.mse, 1, k) / total[None, :, None, None]
        ref = self._slide(self.run.ref_var, 0, k) / total[:, None]
        return k, total, mse, ref

    def rolling(self, width: float = 1.0, level: float = 0.95) -> Rolling:
        """The rolling ratio over windows of ``width``/r_min (module docstring)."""
        run = self.run
        width = check_real("width (in units of 1/r_min)", width, lo=0.0, lo_open=True, hi=run.t[-1] * run.r_min)
        level = check_real("level", level, lo=0.5, hi=1.0, hi_open=True)
        k, total, mse, ref = self._pooled(width)
        mean = mse.mean(axis=0)
        coordinate = np.argmax(mean / ref[:, None, :], axis=2)  # (n, f)
        pick = np.take_along_axis(mean, coordinate[..., None], axis=2)[..., 0]
        den = np.take_along_axis(np.broadcast_to(ref[:, None, :], mean.shape), coordinate[..., None], axis=2)[..., 0]
        seeds = mse.shape[0]
        if seeds > 1:
            spread = np.take_along_axis(mse.std(axis=0, ddof=1), coordinate[..., None], axis=2)[..., 0]
            half = NormalDist().inv_cdf((1 + level) / 2) * spread / np.sqrt(seeds)
            low, high = np.sqrt(np.maximum(pick - half, 0.0) / den), np.sqrt((pick + half) / den)
        else:
            low = high = np.full(pick.shape, np.nan)
        sigma_hat = (self._slide(self.sigma_hat, 1, k) / total[None, :, None]).mean(axis=0)  # nan once diverged
        edges = run.t * run.r_min
        centre = (edges[:-k] + edges[k:]) / 2
        return Rolling(
            centre,
            np.sqrt(pick / den),
            low,
            high,
            coordinate,
            self._slide(run.sigma, 0, k) / total,
            sigma_hat,
            float(edges[k] - edges[0]),
        )

    def periods(
        self, periods: Sequence[Period] | None = None, *, burn: float = 2.0, level: float = 0.95
    ) -> PeriodRatios:
        """The period statistic (:func:`isl_core.period_ratios`): every filter's normalized RMSE ratio
        over ``periods`` (default :func:`isl_core.scenario_periods` of the run's scenario after
        ``burn``), pooled over the seeds, with Student's interval over them. Periods should start and end at window
        edges (plan the runs with :func:`!isl_core.scenario.periods.edge_times`, or with windows short enough): a period
        takes the windows that lie within it."""
        from .periods import period_ratios, scenario_periods

        run = self.run
        if periods is None:
            periods = scenario_periods(run.scenario, float(run.t[-1] * run.r_min), burn=burn)
        return period_ratios(self.mse, run, tuple(periods), level=level)

    def worst(
        self, *, width: float = 1.0, burn: float = 2.0, level: float = 0.95, rng_seed: int = BOOT_SEED
    ) -> tuple[np.ndarray, ...]:
        """Per filter, :func:`!worst_ratio` over the sliding windows of ``width`` that start at or after ``burn``
        (1/r_min): (point, low, high). Needs 2 seeds or more. Biased upwards: a maximum over noisy windows (the
        clairvoyant filter reads 1.1–1.35 on it); the table's statistic is :meth:`periods`."""
        run = self.run
        if len(self.seeds) < 2:
            raise ValueError("a worst case with an interval needs 2 seeds or more")
        burn = check_real("burn (in units of 1/r_min)", burn, lo=0.0, hi=run.t[-1] * run.r_min, hi_open=True)
        _, total, mse, ref = self._pooled(width)
        keep = run.starts_after(burn)[: len(total)]
        if not np.any(keep):
            raise ValueError(f"no window of {width:g}/r_min starts after the burn-in of {burn:g}/r_min")
        return worst_ratio(mse[:, keep], ref[keep], level, np.random.default_rng(rng_seed))


def average_scenario(
    model: Model,
    nu: float,
    scenario: Scenario | None = None,
    *,
    seeds: Sequence[int] = tuple(range(16)),
    horizon: float = 30.0,
    windows: int = 300,
    extra: Sequence[FilterSpec] = (),
    progress: Callable[[float], None] | None = None,
    done: int = 0,
    total: int | None = None,
    edges: Sequence[float] | None = None,
    grid_filters: Sequence[FilterSpec] | None = None,
) -> ScenarioAverage:
    """One :func:`isl_core.simulate_scenario` per seed of ``seeds`` (same arguments otherwise; set up
    once: :func:`isl_core.plan_scenario`, ``edges`` and ``grid_filters`` too, e.g. a tuning's
    :meth:`isl_core.Tuning.grid_filters`); ``progress`` gets (done + runs so far)/total.

    Parameters
    ----------
    model : Model
        The model at σ(0).
    nu : float
        The ISL filter's tuning.
    scenario : Scenario, optional
        What the world does (default: paper A's model).
    seeds : sequence of int
        The noises.
    horizon : float, default 30.0
        Length in units of 1/r_min at σ(0).
    windows : int, default 300
        Equal time windows (or the windows between ``edges``).
    extra : sequence of FilterSpec
        More filters on the same noise.
    progress, done, total : callable, int, int
        ``progress`` gets (``done`` + runs so far)/``total``.
    edges, grid_filters : sequence of float, sequence of FilterSpec
        As in :func:`plan_scenario`.

    Returns
    -------
    ScenarioAverage
        ``mse`` (seeds, windows, filters, m), the run's layout in ``run``, and its rolling and period statistics.

    Examples
    --------
    >>> from isl_core import average_scenario
    >>> from isl_core import Model, Scenario
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> rise = Scenario(sigma_knots=((5.0, 40.0),))  # σ doubles at t = 5/r_min
    >>> avg = average_scenario(model, model.beta, rise, seeds=range(2), horizon=10.0, windows=5)
    >>> avg.mse.shape  # seeds × windows × filters × coordinates
    (2, 5, 3, 3)
    """
    seeds = tuple(check_int("seed", s, lo=0) for s in seeds)
    if not seeds:
        raise ValueError("seeds must name at least one seed")
    plan = plan_scenario(
        model, nu, scenario, horizon=horizon, windows=windows, extra=extra, edges=edges, grid_filters=grid_filters
    )
    runs = []
    for s, seed in enumerate(seeds):
        runs.append(plan.run(seed))
        if progress is not None:
            progress((done + s + 1) / (total or len(seeds)))
    return ScenarioAverage(runs[0], seeds, np.array([r.mse for r in runs]), np.array([r.sigma_hat for r in runs]))
