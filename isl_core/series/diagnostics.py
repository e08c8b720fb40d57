"""Judging the filters without a truth: their one-step predictions of readings they have not yet seen
(:ref:`data-diagnostics`).

The model is fitted on the first part of the series (:func:`isl_core.series.fit`, or m chosen by BIC); every filter
then runs over the whole series with those parameters, and is judged on the held-out tail only, by its innovations
v_k = z_k − ẑ_k (ẑ_k its prediction of z_k from the readings before):

* the prediction RMSE √(mean v_k²);
* the mean normalized innovation squared, NIS = mean v_k²/S_k with S_k the variance the filter states for v_k: 1 for
  a filter whose stated variance is right; for n independent χ²₁ terms n·NIS is χ²_n, whose central 95 % interval
  divided by n is the interval given (a NIS outside it says the stated variance is wrong);
* the Ljung–Box test (statsmodels) of the standardized innovations v_k/√S_k (v_k where no S_k is stated) up to
  ``min(10, n/5)`` lags: a small p-value says they are correlated, i.e. the filter leaves predictable structure;
* the predictive log-likelihood Σ log p(z_k | readings before) under the filter's stated Gaussian (the IMM's
  mixture): the larger the better, comparable between filters on the same readings.

A filter that states no variance (the ISL filters) gets neither NIS nor a predictive log-likelihood: NaN, with a note.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..validate import check_real
from .mle import Fit, fit, select_order
from .record import MIN_READINGS, Series
from .run import SeriesRun, SeriesTrack, run_filters, sigma_range

__all__ = ["HOLDOUT", "Diagnostics", "Judgement", "diagnose", "judge"]

HOLDOUT = 0.2  #: the default share of the times held out for judging (the tail)
LEVEL = 0.95  #: the NIS interval's probability


@dataclass(frozen=True)
class Diagnostics:
    """One filter's diagnostics on ``n`` held-out readings (module docstring); NaN where it states no variance
    (``note`` says so)."""

    name: str
    label: str
    n: int
    rmse: float
    nis: float
    nis_interval: tuple[float, float]
    ljung_box_p: float
    lags: int
    predictive_loglik: float
    note: str = ""

    def as_dict(self) -> dict[str, object]:
        """The diagnostics as plain values (the command line's output)."""
        return {
            "name": self.name,
            "label": self.label,
            "n": self.n,
            "rmse": self.rmse,
            "nis": self.nis,
            "nis_interval": list(self.nis_interval),
            "ljung_box_p": self.ljung_box_p,
            "lags": self.lags,
            "predictive_loglik": self.predictive_loglik,
            "note": self.note,
        }


@dataclass(frozen=True)
class Judgement:
    """The fit on the times before ``split``, the run of every filter, and their ``diagnostics`` on the rest;
    ``orders`` the fit of every m when m was chosen by BIC (else empty)."""

    fit: Fit
    split: int
    run: SeriesRun
    diagnostics: tuple[Diagnostics, ...]
    orders: tuple[Fit, ...] = ()


def _ljung_box(x: np.ndarray, lags: int) -> float:
    try:
        from statsmodels.stats.diagnostic import acorr_ljungbox
    except ImportError as exc:  # pragma: no cover - the data extra is missing
        raise ImportError("the Ljung–Box test needs statsmodels: pip install 'isl[data]'") from exc
    if not np.all(np.isfinite(x)) or np.ptp(x) == 0.0:
        return math.nan
    return float(acorr_ljungbox(x, lags=[lags], return_df=True)["lb_pvalue"].iloc[0])


def diagnose(track: SeriesTrack, tail: np.ndarray) -> Diagnostics:
    """The diagnostics (module docstring) of ``track`` on the readings of mask ``tail`` (N,)."""
    keep = tail & np.isfinite(track.innovation)
    v, s = track.innovation[keep], track.innovation_var[keep]
    n = len(v)
    from scipy.stats import chi2  # here, not at the top: the page imports this module

    lo, hi = chi2.ppf([(1 - LEVEL) / 2, (1 + LEVEL) / 2], n) / n
    stated = bool(np.all(np.isfinite(s)) and np.all(s > 0))
    lags = max(1, min(10, n // 5))
    with np.errstate(all="ignore"):
        rmse = float(np.sqrt(np.mean(v * v))) if np.all(np.isfinite(v)) else math.inf
        nis = float(np.mean(v * v / s)) if stated else math.nan
        lpd = float(np.sum(track.log_density[keep])) if stated else math.nan
        lb = _ljung_box(v / np.sqrt(s) if stated else v, lags)
    note = "" if stated else "states no variance for its predictions: no NIS, no predictive likelihood"
    if not math.isfinite(rmse):
        note = "its estimates left the finite numbers"
    return Diagnostics(track.name, track.label, n, rmse, nis, (float(lo), float(hi)), lb, lags, lpd, note)


def judge(
    series: Series,
    *,
    m: int | None = None,
    alpha: float | None = None,
    holdout: float = HOLDOUT,
    nu: float | None = None,
    progress: Callable[[float], None] | None = None,
    cancel: Callable[[], bool] | None = None,
) -> Judgement:
    """Fit on the first part of ``series``, run every filter, judge each on the held-out tail (module docstring).

    Parameters
    ----------
    series : Series
        The readings.
    m : int, optional
        The order (default: chosen by BIC over 1 … 6).
    alpha : float, optional
        α fixed instead of fitted.
    holdout : float
        The share of the times held out, 0.05 … 0.9.
    nu : float, optional
        The ISL filters' ν (default the fitted β).
    progress, cancel : callable, optional
        As in :func:`isl_core.select_order`.

    Returns
    -------
    Judgement
        The fit, the run and the diagnostics.
    """
    holdout = check_real("holdout", holdout, lo=0.05, hi=0.9)
    split = round((1.0 - holdout) * series.n)
    head, tail = series.present[:split].sum(), series.present[split:].sum()
    if head < MIN_READINGS or tail < MIN_READINGS:
        raise ValueError(
            f"holdout must leave at least {MIN_READINGS} readings on each side, got {head} before and {tail} after"
        )
    part = series.head(split)
    orders: tuple[Fit, ...] = ()
    if m is None:
        choice = select_order(part, alpha=alpha, progress=progress, cancel=cancel)
        fitted, orders = choice.best, choice.fits
    else:
        fitted = fit(part, m, alpha=alpha)
    if cancel is not None and cancel():
        raise InterruptedError("the fit was cancelled")
    # the σ-learners' range and start from the fitted part too: nothing of the judged tail reaches the filters' set-up
    run = run_filters(series, fitted.params, nu=nu, sigma_range_=sigma_range(part))
    mask = np.zeros(series.n, dtype=bool)
    mask[split:] = True
    return Judgement(fitted, split, run, tuple(diagnose(tr, mask) for tr in run.tracks), orders)
