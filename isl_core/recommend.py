"""Computed choice of the ISL tuning ν: minimise the worst-case RMSE ratio over a range of σ (A.31, :ref:`worst-case`).

Paper A reads a recommended ν/β per α off its Fig. 2 by eye (table A.31). Here

    ν* = argmin_ν  max_{σ ∈ sigmas, i = 1..m}  š_i(ν, σ)/s_i(σ)

is found on the statistical-linearization prediction (B.48, :ref:`linearized-covariance`): a grid in log₂(ν/β) then a
bounded scalar refinement around its best point. The answer is then *verified* by simulation (:func:`isl_core.sweep`)
and returned with its simulated worst-case ratio and interval. For comparison the best fixed-gain
Kalman–Bucy filter (designed for one σ̄ ∈ [min σ, max σ], :ref:`mismatched-kbf`) has its own predicted worst case.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from .bounds import BOUNDS
from .model import Model
from .paper import FIG2_SIGMAS
from .requests import Execution, Sampling
from .sweep import check_requests, sweep
from .theory import mismatched_kbf_ratios, predicted_ratios_grid
from .validate import check_real, check_reals, short

__all__ = ["Recommendation", "WorstCase", "best_fixed_kbf", "recommend_nu", "worst_case_theory"]

LOG2_RANGE = (-12.0, 4.0)  #: search interval of log₂(ν/β)
GRID_STEP = 1.0 / 16.0  #: spacing of the coarse search grid in log₂(ν/β)


@dataclass(frozen=True)
class WorstCase:
    """Worst case over σ and i of one ν/β: predicted, and simulated with its interval (nan if not simulated)."""

    nu_over_beta: float
    theory: float
    simulated: float
    low: float
    high: float
    sigma: float
    i: int


@dataclass(frozen=True)
class Recommendation:
    """Recommended ν for one α and its worst-case ratios (over ``sigmas`` and coordinates).

    ``theory_worst`` predicted (:ref:`linearized-covariance`); ``simulated_worst`` measured with interval
    ``[simulated_low, simulated_high]`` (the max over σ, i of each bound), nan if not verified;
    ``worst_sigma``, ``worst_i`` where the simulated (else predicted) worst case sits;
    ``kbf_worst``/``kbf_sigma_design``: the best fixed-gain Kalman–Bucy filter's predicted worst case;
    ``compared``: the worst cases of the ``compare`` values of ν/β, simulated on the same noise;
    ``model_aware``: the recommendation is for the ISL filter that propagates with A. The simulation's averaging
    window per σ (``sigmas`` order): a burn-in of ``burn·stretch[j]/r_min`` (the sampling's burn-in), then
    ``horizon·stretch[j]/r_min`` (:func:`!isl_core.sweep.group_length`); ``stretch`` is empty when not verified.
    """

    alpha: float
    beta: float
    m: int
    w: float
    sigmas: tuple[float, ...]
    nu: float
    nu_over_beta: float
    theory_worst: float
    simulated_worst: float
    simulated_low: float
    simulated_high: float
    worst_sigma: float
    worst_i: int
    kbf_worst: float
    kbf_sigma_design: float
    compared: tuple[WorstCase, ...] = ()
    model_aware: bool = False
    horizon: float = math.nan
    stretch: tuple[float, ...] = ()


def worst_case_theory(
    alpha: float,
    nu_over_beta: npt.ArrayLike,
    *,
    sigmas: Sequence[float] = FIG2_SIGMAS,
    m: int = 3,
    w: float = 3.0,
    model_aware: bool = False,
) -> np.ndarray:
    """Predicted ``max_{σ, i} š_i/s_i`` for each ν/β (same shape as ``nu_over_beta``), β = w√(2α) (A.25).

    ``model_aware``: of the ISL filter that propagates with A (damp = α) instead of A0.
    """
    x = np.asarray(nu_over_beta, dtype=float)
    worst = np.full(x.size, -np.inf)
    for sigma in sigmas:
        model = Model.from_w(alpha, w, sigma, m)
        damp = model.alpha if model_aware else None
        worst = np.maximum(worst, predicted_ratios_grid(model, model.beta * x.ravel(), damp=damp).max(axis=1))
    return worst.reshape(x.shape)


def _search(alpha: float, sigmas: Sequence[float], m: int, w: float, model_aware: bool = False) -> float:
    """log₂(ν*/β) minimising the predicted worst case: grid, then bounded Brent around the grid's best."""
    from scipy.optimize import minimize_scalar  # lazy: scipy.optimize is slow to import

    kw: dict[str, Any] = {"sigmas": sigmas, "m": m, "w": w, "model_aware": model_aware}
    grid = np.arange(LOG2_RANGE[0], LOG2_RANGE[1] + GRID_STEP / 2, GRID_STEP)
    worst = worst_case_theory(alpha, 2.0**grid, **kw)
    k = int(np.argmin(worst))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    res = minimize_scalar(
        lambda ell: float(worst_case_theory(alpha, 2.0**ell, **kw)),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-4},
    )
    return float(res.x) if res.fun <= worst[k] else float(grid[k])


def best_fixed_kbf(
    alpha: float, *, sigmas: Sequence[float] = FIG2_SIGMAS, m: int = 3, w: float = 3.0, n: int = 49
) -> tuple[float, float]:
    """Best design σ̄ (log grid of ``n`` points in [min σ, max σ]) of a fixed-gain Kalman–Bucy filter and its
    predicted worst case ``max_{σ, i}`` ratio (:ref:`minimax-kbf`). Returns ``(worst, sigma_design)``."""
    designs = np.geomspace(min(sigmas), max(sigmas), n)
    worst = [max(float(mismatched_kbf_ratios(Model.from_w(alpha, w, s, m), d).max()) for s in sigmas) for d in designs]
    k = int(np.argmin(worst))
    return worst[k], float(designs[k])


def recommend_nu(
    alpha: float,
    *,
    sigmas: Sequence[float] | np.ndarray = FIG2_SIGMAS,
    m: int = 3,
    w: float = 3.0,
    verify: bool = True,
    compare: Sequence[float] = (),
    model_aware: bool = False,
    sampling: Sampling | None = None,
    execution: Execution | None = None,
) -> Recommendation:
    """The ν minimising the predicted worst-case ratio over ``sigmas`` and coordinates, verified by simulation.

    β = w√(2α) (A.25). ``verify=False`` skips the simulation (simulated fields nan). ``compare``: other values
    of ν/β (e.g. a published table) whose worst cases are computed alongside, on the same noise.
    ``sampling`` and ``execution`` go to :func:`isl_core.sweep`. ``model_aware``: recommend ν for the ISL filter
    that propagates with A (:func:`!isl_core.filters.isl.model_aware_isl`) instead of paper A's (A0).

    Parameters
    ----------
    alpha : float
        The model's α > 0.
    sigmas : sequence of float
        The σ range over which the worst case is taken (default paper A's Fig. 2).
    m : int, default 3
        State dimension.
    w : float, default 3.0
        Stationary std of X_m (β = w√(2α)).
    verify : bool, default True
        Also simulate the recommendation (and ``compare``).
    compare : sequence of float
        Other values of ν/β whose worst cases are computed alongside.
    model_aware : bool, default False
        Recommend ν for the ISL filter that propagates with A.
    sampling, execution : Sampling, Execution, optional
        As in :func:`isl_core.sweep`.

    Returns
    -------
    Recommendation
        ``nu``, its predicted worst case ``theory_worst`` and, if verified, the simulated one with its interval.

    Examples
    --------
    >>> import math
    >>> from isl_core import recommend_nu
    >>> rec = recommend_nu(0.5, sigmas=[2.0, 20.0], verify=False)
    >>> bool(rec.nu > 0 and rec.theory_worst >= 1.0), math.isnan(rec.simulated_worst)
    (True, True)
    """
    alpha = check_real("alpha", alpha, lo=0.0, lo_open=True)  # β = w·√(2α) needs α > 0
    sig = list(BOUNDS.sigma.reals(sigmas, "sigmas"))
    m = BOUNDS.m.whole(m)
    w = BOUNDS.w.real(w)
    compare = list(check_reals("compare", compare, lo=0.0, lo_open=True, allow_empty=True))
    if not isinstance(model_aware, bool):
        raise ValueError(f"model_aware must be True or False, got {short(model_aware)}")
    sampling, execution = check_requests(sampling, execution)
    beta = w * math.sqrt(2.0 * alpha)
    ell = _search(alpha, sig, m, w, model_aware)
    nob = 2.0**ell
    kbf_worst, kbf_design = best_fixed_kbf(alpha, sigmas=sig, m=m, w=w)
    cases, stretch = _worst_cases(
        [nob, *compare],
        alpha,
        sig,
        m,
        w,
        verify,
        dict(sampling=sampling, execution=execution, model_aware=model_aware),
    )
    c = cases[0]
    return Recommendation(
        alpha,
        beta,
        m,
        w,
        tuple(sig),
        beta * nob,
        nob,
        c.theory,
        c.simulated,
        c.low,
        c.high,
        c.sigma,
        c.i,
        kbf_worst,
        kbf_design,
        tuple(cases[1:]),
        model_aware,
        sampling.horizon if verify else math.nan,
        stretch,
    )


def _worst_cases(
    nobs: Sequence[float],
    alpha: float,
    sigmas: list[float],
    m: int,
    w: float,
    verify: bool,
    kw: dict[str, Any],
) -> tuple[list[WorstCase], tuple[float, ...]]:
    """Worst case over σ, i of every ν/β in ``nobs`` — simulated in one sweep (same noise) when ``verify`` — and
    that sweep's lengthening per σ (empty when not verified)."""
    cases = []
    stretch: tuple[float, ...] = ()
    if verify:
        res = sweep([alpha], sigmas, nobs, m=m, w=w, **kw)
        stretch = tuple(float(x) for x in res.stretch[0])
    damp = alpha if kw["model_aware"] else None
    for n, nob in enumerate(nobs):
        theory = float(worst_case_theory(alpha, nob, sigmas=sigmas, m=m, w=w, model_aware=kw["model_aware"]))
        if verify:
            ratio = res.ratio[0, :, n]  # (nσ, m)
            b, i = np.unravel_index(int(np.nanargmax(ratio)), ratio.shape)
            sim = float(ratio[b, i])
            low, high = float(res.ratio_low[0, :, n].max()), float(res.ratio_high[0, :, n].max())
        else:
            ratio = np.array(
                [
                    predicted_ratios_grid(Model.from_w(alpha, w, s, m), [nob * w * math.sqrt(2 * alpha)], damp=damp)[0]
                    for s in sigmas
                ]
            )
            b, i = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
            sim = low = high = math.nan
        cases.append(WorstCase(float(nob), theory, sim, low, high, float(sigmas[b]), int(i) + 1))
    return cases, stretch
