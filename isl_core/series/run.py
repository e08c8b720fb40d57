"""Every filter over a recorded series (:ref:`data-filters`): the Kalman filter at a given σ_r, paper A's and the
model-aware ISL filters, the adaptive, variational-Bayes, robust and IMM filters.

The filters are the project's own (:mod:`isl_core.filters`), built for the model (A.19) of the reading model's
m, α, β and σ = σ_r·√Δ̄ (:func:`isl_core.series.record.sigma_of_reading`, Δ̄ the typical interval); the σ-free ones
use only m, α, β — the ISL filters' ν (default β, paper A's Fig. 3), the σ-learners' range (default
:func:`!sigma_range` of the readings). They run through the compiled loops of :mod:`isl_core.kernels.series`, with
the exact transition between readings. Every filter starts at X₁ = the first reading, the other coordinates 0.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._engine import pack
from ..filters import adaptive_kbf, imm_kbf, isl_filter, model_aware_isl, robust_kbf, variational_kbf
from ..filters.adaptive import MEMORY, sigma_limit
from ..filters.base import FilterSpec
from ..kernels.imm import imm_state
from ..kernels.series import imm_series, spec_series, vb_series
from ..model import Model
from ..scenario.learners import learning_state
from ..validate import check_real, short
from .discretize import ONE_THREAD, Steps, steps, van_loan
from .likelihood import ReadingModel, kalman_track
from .record import Series

__all__ = ["SERIES_FILTERS", "SeriesRun", "SeriesTrack", "run_filters", "series_specs", "sigma_range"]

#: the filters of a series run, by stable name, in their order
SERIES_FILTERS = ("kalman", "isl", "isl_model", "kbf_adaptive", "vb", "kbf_robust", "imm")
LOG_2PI = math.log(2.0 * math.pi)


@dataclass(frozen=True)
class SeriesTrack:
    """One filter over a series: ``estimate`` (N, m) after each reading, ``variance`` (N, m) the diagonal of its
    stated covariance (None if it states none), ``prediction`` (N,) of each reading before it, ``innovation`` (N,)
    z_k − prediction (NaN where missing), ``innovation_var`` (N,) the variance it states for that innovation (NaN if
    none), ``log_density`` (N,) its predictive log-density of each reading (NaN where missing or none stated)."""

    name: str
    label: str
    estimate: np.ndarray
    variance: np.ndarray | None
    prediction: np.ndarray
    innovation: np.ndarray
    innovation_var: np.ndarray
    log_density: np.ndarray


@dataclass(frozen=True)
class SeriesRun:
    """Every filter of :func:`run_filters` over ``series`` at ``params``, and the ISL filters' ``nu``."""

    series: Series
    params: ReadingModel
    nu: float
    tracks: tuple[SeriesTrack, ...]

    def track(self, name: str) -> SeriesTrack:
        """The track of the filter ``name``."""
        for tr in self.tracks:
            if tr.name == name:
                return tr
        raise KeyError(name)


def sigma_range(series: Series) -> tuple[float, float]:
    """The σ-learners' default σ range: s/1000 … 10·s, s = sd of the readings' first differences × √Δ̄ (a bound on σ
    from the readings alone, since Var(z_{k+1} − z_k) ≥ 2σ_r²); they start at σ̂ = s."""
    d = np.diff(series.z)
    d = d[np.isfinite(d)]
    s = float(np.std(d)) * math.sqrt(series.spacing) if len(d) > 1 else 0.0
    s = s if s > 0.0 else 1.0
    return s / 1000.0, 10.0 * s


def _track(
    spec_name: str,
    label: str,
    z: np.ndarray,
    est: np.ndarray,
    var: np.ndarray | None,
    pred: np.ndarray,
    svar: np.ndarray,
    lpd: np.ndarray | None = None,
) -> SeriesTrack:
    innov = z - pred
    if lpd is None:
        with np.errstate(divide="ignore", invalid="ignore"):
            lpd = -0.5 * (LOG_2PI + np.log(svar) + innov**2 / svar)
    return SeriesTrack(spec_name, label, est, var, pred, innov, svar, lpd)


def _spec_track(series: Series, st: Steps, model: Model, spec: FilterSpec) -> SeriesTrack:
    n, m = series.n, model.m
    bank = pack(model, [spec], scenario=True)
    vb_P, vb_ab, vb_par = learning_state(model, [spec], bank.ad)
    F = st.transition(m, spec.damp)
    sqd = np.sqrt(st.before)
    est, pred, svar = np.full((n, m), np.nan), np.full(n, np.nan), np.full(n, np.nan)
    var = None
    k0 = int(np.flatnonzero(series.present)[0])  # the start: X₁ = the first reading, the rest 0
    est[k0] = 0.0
    est[k0, 0] = series.z[k0]
    if spec.variational is not None:
        _, Q = van_loan(m, spec.damp, model.beta, st.dt)
        var = np.full((n, m), np.nan)
        vb_series(series.z, st.index, sqd, F, Q, vb_P[0], vb_ab[0], vb_par[0], k0, est, var, pred, svar)
    elif spec.imm is not None:
        _, Q = van_loan(m, spec.damp, model.beta, st.dt)
        bank_imm = imm_state([spec], m, 1, 1.0)
        bank_imm.e[0, :, 0] = est[k0, 0]
        var, lpd = np.full((n, m), np.nan), np.full(n, np.nan)
        var[k0] = np.einsum("j,jii->i", bank_imm.mu[0], bank_imm.P[0, :, :m, :m])
        imm_series(series.z, st.index, sqd, F, Q, bank_imm, k0, est, var, pred, svar, lpd)
        return _track(spec.name, spec.label, series.z, est, var, pred, svar, lpd)
    else:
        args = (spec.kind, spec.coef, bank.table, bank.ad, vb_par[0], k0, est, pred, svar)
        spec_series(series.z, st.index, sqd, F, *args)
    return _track(spec.name, spec.label, series.z, est, var, pred, svar)


def series_specs(
    model: Model, nu: float, sr: tuple[float, float], memory: float, names: Sequence[str]
) -> dict[str, FilterSpec]:
    """The σ-free filters of ``names`` for ``model`` (its m, α, β): the ISL filters at ``nu``, the σ-learners over the
    σ range ``sr`` (its top held below the Riccati equation's domain) with memory ``memory``, starting at σ̂ = sr[1]/10.
    """
    lo, hi = sr
    hi = min(hi, 0.5 * sigma_limit(model))
    lo = min(lo, hi / 10.0)
    guess = hi / 10.0  # a large σ̂ first: a small gain, stable however coarse the readings; the data take over
    makers = {
        "isl": lambda: isl_filter(model, nu),
        "isl_model": lambda: model_aware_isl(model, nu),
        "kbf_adaptive": lambda: adaptive_kbf(model, sigma_range=(lo, hi), memory=memory, sigma_init=guess),
        "vb": lambda: variational_kbf(model, sigma_init=guess, memory=memory),
        "kbf_robust": lambda: robust_kbf(model, sigma_range=(lo, hi), memory=memory, sigma_init=guess),
        "imm": lambda: imm_kbf(model, sigma_range=(lo, hi)),
    }
    return {name: makers[name]() for name in names if name in makers}


@ONE_THREAD
def run_filters(
    series: Series,
    params: ReadingModel,
    *,
    nu: float | None = None,
    names: Sequence[str] = SERIES_FILTERS,
    sigma_range_: tuple[float, float] | None = None,
    memory: float = MEMORY,
) -> SeriesRun:
    """Run the filters ``names`` (default :data:`!SERIES_FILTERS`) over ``series`` (module docstring).

    Parameters
    ----------
    series : Series
        The readings.
    params : ReadingModel
        m, α, β for every filter; σ_r for the Kalman filter only.
    nu : float, optional
        The ISL filters' ν (default β).
    names : sequence of str
        The filters, among :data:`!SERIES_FILTERS`.
    sigma_range_ : (float, float), optional
        The σ-learners' range of (A.19)'s σ (default :func:`!sigma_range`).
    memory : float
        The σ-learners' memory W in readings.

    Returns
    -------
    SeriesRun
        One :class:`SeriesTrack` per filter, in the order of ``names``.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core.series import ReadingModel, run_filters, series
    >>> s = series(np.arange(50.0), np.cumsum(np.sin(np.arange(50.0))))
    >>> run = run_filters(s, ReadingModel(2, 0.0, 0.3, 0.5))
    >>> [tr.name for tr in run.tracks] == ["kalman", "isl", "isl_model", "kbf_adaptive", "vb", "kbf_robust", "imm"]
    True
    """
    names = tuple(names)
    bad = [n for n in names if n not in SERIES_FILTERS]
    if bad or not names:
        raise ValueError(f"names must be some of {list(SERIES_FILTERS)}, got {short(list(names))}")
    nu = params.beta if nu is None else check_real("nu", nu, lo=0.0, lo_open=True)
    # in units of the readings' spread s and the typical interval d (X_i in s/d^(i−1)), mapped back after: every
    # filter is equivariant under this change of units (ν and σ scale as β and σ do), and the numbers stay in range
    s, d, m = float(np.std(series.z[series.present])) or 1.0, series.spacing, params.m
    k_beta = d ** (m - 0.5) / s
    unit = Series((series.t - series.t[0]) / d, series.z / s, series.name, series.unit)
    p_n = ReadingModel(m, params.alpha * d, params.beta * k_beta, params.sigma_r / s)
    sr = sigma_range(unit) if sigma_range_ is None else (sigma_range_[0] / (s * d**0.5), sigma_range_[1] / (s * d**0.5))
    run = _run_units(unit, p_n, nu * k_beta, names, sr, memory)
    scale = s / d ** np.arange(m)
    for tr in run:  # back to the series' units, in place (no second copy of N × filters arrays)
        tr.estimate[...] *= scale
        if tr.variance is not None:
            with np.errstate(over="ignore"):  # as in likelihood._run: X_i's variance, i ≥ 2, may pass the range
                tr.variance[...] *= scale**2
        tr.prediction[...] *= s
        np.subtract(series.z, tr.prediction, out=tr.innovation)
        tr.innovation_var[...] *= s * s
        tr.log_density[...] -= math.log(s)
    return SeriesRun(series, params, float(nu), tuple(_relabel(tr, params, float(nu), s * d**0.5) for tr in run))


def _relabel(track: SeriesTrack, params: ReadingModel, nu: float, k_sigma: float) -> SeriesTrack:
    """``track``'s label in the series' units (the filters were built in units of the readings' spread and the
    interval: σ_r, ν and the IMM's σ grid scale back by s, β's factor and s·√d; the memory W and Huber's c do not)."""
    label = track.label
    if track.name == "kalman":
        label = f"Kalman (σ_r = {params.sigma_r:.4g} given)"
    elif track.name in ("isl", "isl_model"):
        label = re.sub(r"ν = [^)]*", f"ν = {nu:.4g}", label)
    elif track.name == "imm":
        label = re.sub(
            r"\[([^,\]]+), ([^\]]+)\]", lambda g: f"[{float(g[1]) * k_sigma:.3g}, {float(g[2]) * k_sigma:.3g}]", label
        )
    return dataclasses.replace(track, label=label)


def _run_units(
    series: Series, params: ReadingModel, nu: float, names: Sequence[str], sr: tuple[float, float], memory: float
) -> list[SeriesTrack]:
    model = params.model(series.spacing)
    st = steps(series.t)
    specs = series_specs(model, nu, sr, memory, names)
    tracks = []
    for name in names:
        if name == "kalman":
            _, est, var, pred, svar = kalman_track(series, params)
            label = f"Kalman (σ_r = {params.sigma_r:.4g} given)"
            tracks.append(_track("kalman", label, series.z, est, var, pred, svar))
        else:
            tracks.append(_spec_track(series, st, model, specs[name]))
    return tracks
