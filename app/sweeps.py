"""ν-sweeps behind the dashboard's Fig. 2 view (paper A, Fig. 2; :ref:`theory`).

For the current α, β and m and a few σ: the ISL filter's RMSE ratio ``š_i/s_i`` against ``ν/β = 2^ℓ``.

* Theory curves: statistical linearization (B.48 and its α > 0 extension, :mod:`isl_core.theory`), a
  batched Lyapunov solve per σ — instant. Extra filters (:mod:`app.extras`) add theirs: the model-aware ISL
  filter's curve over the same ν, the fixed-gain Kalman–Bucy filters' exact Lyapunov ratio (flat in ν); the
  adaptive filter has no theory and no curve.
* Recommended ν: :func:`isl_core.recommend_nu` (minimax over σ on the theory, verified by simulation);
  it uses paper A's parametrization, so it needs α > 0 (w = β/√(2α)).
* Simulated points: the core's sweep (:func:`isl_core.sweep` at the current β, one seed, ``BATCHES`` batches) —
  exactly what ``isl sweep --beta β`` writes for the same inputs. For each σ **one** long run carries the optimal
  Kalman–Bucy filter and the ISL filter at every ν of the grid on the same noise (common random numbers); burn-in
  and horizon are counted in the settling time of the slowest filter of the run, and the 95 % interval of each
  ratio is the core's batch-means interval. The Kalman–Bucy column must sit at 1 within its interval: it is the
  check that the horizon is long enough.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from isl_core import (
    SWEEP_BURN,
    Execution,
    Model,
    Sampling,
    baseline_filters,
    predicted_ratios_grid,
    recommend_nu,
    sweep,
    theory_ratios,
)

from .extras import SIGMA_DESIGN, SIGMA_RANGE
from .text import per_r_min

__all__ = [
    "BATCHES",
    "SIM_LEVELS",
    "THEORY_LEVELS",
    "SweepCurves",
    "SweepPoints",
    "simulate_points",
    "theory_curves",
]

THEORY_LEVELS = np.linspace(-8.0, 2.0, 81)  #: ℓ of the theory curves, ν/β = 2^ℓ (paper A: ℓ = −8..2)
SIM_LEVELS = np.arange(-8, 3).astype(float)  #: ℓ of the simulated points
BATCHES = 10  #: batch means for the confidence intervals


@dataclass(frozen=True)
class SweepCurves:
    """Predicted ratios ``ratios[s, k, i]`` at σ = ``sigmas[s]``, ν/β = ``nu_over_beta[k]``, coordinate i.

    ``extra[name]``: the same (S, K, m) for an extra filter with a theory (module docstring).
    """

    alpha: float
    beta: float
    m: int
    sigmas: tuple[float, ...]
    nu_over_beta: np.ndarray
    ratios: np.ndarray
    extra: dict = field(default_factory=dict)


@dataclass(frozen=True)
class SweepPoints:
    """Simulated ratios (S, K, m) of the ISL filter with their 95 % interval ``[low, high]``; ``kbf*`` (S, m) the
    optimal filter's — read from the core's :class:`isl_core.SweepResult` at one α."""

    alpha: float
    beta: float
    m: int
    sigmas: tuple[float, ...]
    nu_over_beta: np.ndarray
    ratio: np.ndarray
    low: np.ndarray
    high: np.ndarray
    kbf: np.ndarray
    kbf_low: np.ndarray
    kbf_high: np.ndarray
    horizon: float
    seed: int
    stretch: tuple[float, ...] = ()


def theory_curves(
    alpha: float,
    beta: float,
    m: int,
    sigmas: Sequence[float],
    *,
    extras: Sequence[str] = (),
    sigma_design: float = SIGMA_DESIGN,
    sigma_range: tuple[float, float] = SIGMA_RANGE,
) -> SweepCurves:
    """Predicted ``š_i/s_i`` over ``ν/β = 2^THEORY_LEVELS`` for each σ (B.48, :ref:`linearization`); inf where unstable.

    ``extras``: names of extra filters whose curves to add (``sigma_design``, ``sigma_range`` as in
    :func:`isl_core.baseline_filters`).
    """
    nob = 2.0**THEORY_LEVELS
    ratios = np.stack([predicted_ratios_grid(Model(alpha, beta, s, m), beta * nob) for s in sigmas])
    extra = {
        name: np.stack([_extra_curve(Model(alpha, beta, s, m), name, nob, sigma_design, sigma_range) for s in sigmas])
        for name in extras
        if name != "kbf_adaptive"
    }
    return SweepCurves(alpha, beta, m, tuple(sigmas), nob, ratios, extra)


def _extra_curve(model: Model, name: str, nob: np.ndarray, sigma_design: float, sigma_range) -> np.ndarray:
    """(K, m) predicted ratios of extra filter ``name``: over ν for the model-aware ISL filter, flat otherwise."""
    if name == "isl_model":
        return predicted_ratios_grid(model, model.beta * nob, damp=model.alpha)
    (spec,) = baseline_filters(model, nu=model.beta, sigma_design=sigma_design, sigma_range=sigma_range, names=(name,))
    return np.broadcast_to(theory_ratios(model, spec), (len(nob), model.m))


def simulate_points(
    alpha: float,
    beta: float,
    m: int,
    sigmas: Sequence[float],
    *,
    horizon: float,
    seed: int,
    progress: Callable[[float], None] | None = None,
) -> SweepPoints:
    """Simulated ratios at ``ν/β = 2^SIM_LEVELS``: :func:`isl_core.sweep` at this α and β, one seed.

    ``progress(fraction)`` receives the overall fraction done; an exception raised from it cancels.
    """
    res = sweep(
        [alpha],
        sigmas,
        2.0**SIM_LEVELS,
        m=m,
        beta=beta,
        sampling=Sampling((seed,), horizon, batches=BATCHES),
        execution=Execution(workers=1, progress=progress),
    )
    return SweepPoints(
        alpha,
        beta,
        m,
        tuple(float(s) for s in sigmas),
        res.nu_over_beta,
        res.ratio[0],
        res.ratio_low[0],
        res.ratio_high[0],
        res.kbf_ratio[0],
        res.kbf_low[0],
        res.kbf_high[0],
        float(horizon),
        int(seed),
        tuple(float(k) for k in res.stretch[0]),
    )


def recommend(
    alpha: float,
    beta: float,
    m: int,
    sigmas: Sequence[float],
    *,
    horizon: float,
    seed: int,
    progress: Callable[[float], None] | None = None,
) -> tuple[float, str]:
    """``(ν, summary)`` from :func:`isl_core.recommend_nu` with its simulated check (``horizon``, ``seed``)."""
    if alpha <= 0.0:
        raise ValueError("the recommendation needs alpha > 0 (paper A's parametrization β = w√(2α))")
    rec = recommend_nu(
        alpha,
        sigmas=list(sigmas),
        m=m,
        w=beta / np.sqrt(2.0 * alpha),
        sampling=Sampling((seed,), horizon),
        execution=Execution(progress=progress),
    )
    sig = ", ".join(f"{s:g}" for s in sigmas)
    text = (
        f"Recommended ν = {rec.nu:.4g} (ν/β = {rec.nu_over_beta:.3g}) for σ ∈ {{{sig}}}: worst-case ratio "
        f"{rec.theory_worst:.3f} predicted, {rec.simulated_worst:.3f} "
        f"[{rec.simulated_low:.3f}, {rec.simulated_high:.3f}] simulated ({per_r_min(horizon)}). "
        f"Best fixed-gain Kalman–Bucy filter: {rec.kbf_worst:.3f} (designed for σ̄ = {rec.kbf_sigma_design:.3g})."
    )
    return float(rec.nu), text


def points_note(pts: SweepPoints, seconds: float) -> str:
    """Where simulated points come from: their runs' seed, averaging window, any lengthening and the intervals."""
    k_lo, k_hi = min(pts.stretch), max(pts.stretch)
    by = f"×{k_hi:.3g}" if k_lo == k_hi else f"×{k_lo:.3g}–×{k_hi:.3g}"
    longer = (
        ""
        if k_hi == 1.0
        else (f", both lengthened {by} for the slowest ν (its filter settles slower than the optimal one, B.46)")
    )
    return (
        f"Simulated in {seconds:.2g} s: each σ's run (seed {pts.seed}) averages over {per_r_min(pts.horizon)} "
        f"after a burn-in of {per_r_min(SWEEP_BURN)}{longer}; 95 % batch-means intervals."
    )
