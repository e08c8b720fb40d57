"""The Kalman filter of a recorded series at given parameters, and its exact Gaussian log-likelihood (:ref:`data-fit`).

Parameters are a :class:`ReadingModel`: the model's m, α, β (A.19) and the reading noise's standard deviation σ_r
(:mod:`isl_core.series.record`). Between readings the state moves by the exact F, Q (:mod:`~.discretize`); a reading
has variance σ_r². The log-likelihood is the prediction-error decomposition

    log L = Σ_k −½ (log 2π + log S_k + v_k²/S_k),   v_k = z_k − ẑ_k,  S_k = P₁₁(t_k⁻) + σ_r²

**Diffuse start**: the state at the first time is unknown. The filter starts at X₁ = the first reading, the other
coordinates 0, with a variance κ_i = :data:`KAPPA`·s²/Δ̄^(2(i−1)) on X_i (s² the readings' variance, Δ̄ the typical
interval), and the first ``burn`` present readings (m by default: what identifies the m coordinates) add only −½ log 2π
each — the limit κ → ∞ of the approximate diffuse start is the exact diffuse likelihood of Durbin & Koopman ("Time
Series Analysis by State Space Methods", 2nd ed., 2012, §5.2 and §7.2.2), where the diffuse readings' terms log F_∞
vanish for m = 1 and are constants free of β and σ_r otherwise. X_m is diffuse too when α > 0, so that likelihoods
at α = 0 and α > 0 compare.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ..kernels.series import kalman_series
from ..model import M_MAX, Model
from ..validate import check_int, check_real
from .discretize import ONE_THREAD, Steps, steps, van_loan
from .record import Series

#: a known start: x₀ (m,) and P₀ (m, m)
Start = tuple[npt.ArrayLike, npt.ArrayLike]
#: (log L, estimates (N, m), diag P (N, m), predictions (N,), innovation variances (N,))
Track = tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]

__all__ = ["KAPPA", "ReadingModel", "diffuse_start", "kalman_track", "loglik", "loglik_at"]

KAPPA = 1e7  #: the diffuse start's variance, relative to the readings' variance (module docstring)


@dataclass(frozen=True)
class ReadingModel:
    """The model (A.19) of m, α ≥ 0, β > 0 read through a sensor of noise sd σ_r > 0
    (:mod:`!isl_core.series.record`)."""

    m: int
    alpha: float
    beta: float
    sigma_r: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "m", check_int("m", self.m, lo=1, hi=M_MAX))
        object.__setattr__(self, "alpha", check_real("alpha", self.alpha, lo=0.0))
        object.__setattr__(self, "beta", check_real("beta", self.beta, lo=0.0, lo_open=True))
        object.__setattr__(self, "sigma_r", check_real("sigma_r", self.sigma_r, lo=0.0, lo_open=True))

    def model(self, spacing: float) -> Model:
        """The :class:`isl_core.Model` of these α, β, m with σ = σ_r·√Δ for readings every ``spacing`` (A.19)."""
        return Model(self.alpha, self.beta, self.sigma_r * math.sqrt(spacing), self.m)


def diffuse_start(series: Series, m: int) -> tuple[np.ndarray, np.ndarray]:
    """The diffuse start (module docstring): (x₀ (m,), P₀ (m, m))."""
    present = series.z[series.present]
    s2 = float(np.var(present)) or 1.0
    x0 = np.zeros(m)
    x0[0] = present[0]
    P0 = np.diag(KAPPA * s2 / series.spacing ** (2.0 * np.arange(m)))  # what the filter uses, in units of s and Δ̄
    return x0, P0


def _run(
    series: Series,
    rm: ReadingModel,
    start: Start | None,
    burn: int | None,
    store: bool,
    st: Steps | None = None,
) -> Track:
    """The filter; with the diffuse start on the readings in units of their spread s and the times in units of the
    typical interval d (X_i in units of s/d^(i−1): α·d, β·d^(m−½)/s, σ_r/s), mapped back after — the filter is
    linear, so this changes rounding only, and keeps the diffuse start's κ·s² within the float range whatever the
    units."""
    st = steps(series.t) if st is None else st
    m = rm.m
    if start is None:
        z = series.z[series.present]
        s, d = float(np.std(z)) or 1.0, series.spacing
        z_n = series.z / s
        a, b, r = rm.alpha * d, rm.beta * d ** (m - 0.5) / s, rm.sigma_r / s
        x0, P0 = np.zeros(m), KAPPA * np.eye(m)  # diffuse_start in these units: spread 1, interval 1
        x0[0] = z_n[series.present][0]
        burn = m if burn is None else burn
    else:
        s, d, z_n = 1.0, 1.0, series.z
        a, b, r = rm.alpha, rm.beta, rm.sigma_r
        x0, P0 = (np.array(v, dtype=float, copy=True) for v in start)
        burn = 0 if burn is None else burn
    F, Q = van_loan(m, a, b, st.dt / d)
    n = series.n if store else 0
    est, var = np.full((n, m), np.nan), np.full((n, m), np.nan)
    pred, svar = np.full(n, np.nan), np.full(n, np.nan)
    ll = kalman_series(z_n, st.index, F, Q, r * r, x0, P0, burn, est, var, pred, svar, store)
    ll -= max(int(series.present.sum()) - burn, 0) * math.log(s)  # each term's −½ log S_k: S_k = s²·S'_k
    if not store:
        return ll, est, var, pred, svar
    unit = s / d ** np.arange(m)
    with np.errstate(over="ignore"):  # X_i's variance in the series' units may pass the float range (inf): dense
        return ll, est * unit, var * unit**2, pred * s, svar * s * s  # times and large readings, i ≥ 2


@ONE_THREAD
def loglik(series: Series, rm: ReadingModel, *, start: Start | None = None, burn: int | None = None) -> float:
    """The log-likelihood of ``series`` under ``rm`` (module docstring).

    Parameters
    ----------
    series : Series
        The readings.
    rm : ReadingModel
        The parameters.
    start : (array, array), optional
        A known start (x₀ (m,), P₀ (m, m)) at the first time instead of the diffuse one.
    burn : int, optional
        Present readings that add only −½ log 2π (default m with the diffuse start, 0 with a known one).

    Returns
    -------
    float
        log L.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core.series import ReadingModel, loglik, series
    >>> s = series(np.arange(20.0), np.sin(np.arange(20.0)))
    >>> bool(np.isfinite(loglik(s, ReadingModel(1, 0.0, 0.5, 0.5))))
    True
    """
    return float(_run(series, rm, start, burn, store=False)[0])


def loglik_at(series: Series, rm: ReadingModel, st: Steps, *, burn: int | None = None) -> float:
    """:func:`loglik` with the diffuse start on the intervals ``st`` of ``series`` computed once (the fit's inner loop,
    which holds BLAS to one thread itself)."""
    return float(_run(series, rm, None, burn, store=False, st=st)[0])


@ONE_THREAD
def kalman_track(series: Series, rm: ReadingModel, *, start: Start | None = None, burn: int | None = None) -> Track:
    """The Kalman filter at ``rm``'s σ_r over ``series``: (log L, estimates (N, m), diag P (N, m), predictions (N,),
    innovation variances (N,)) — the filter of :func:`loglik`, every output kept."""
    return _run(series, rm, start, burn, store=True)
