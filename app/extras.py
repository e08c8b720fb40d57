"""The dashboard's baselines: extra filters on the same run, and the worst case over an unknown σ.

A user who does not know σ could run, instead of the ISL filter, a Kalman–Bucy filter designed for a guessed
σ̄ ("mismatched"), one designed for the top of the plausible σ range ("minimax"), an adaptive one that
estimates σ online, or the model-aware ISL filter that propagates with A = A0 − αEEᵀ
(:mod:`isl_core.filters.baselines`); and the worst-case comparison of :func:`isl_core.worst_case`: for the σ range
``[σ min, σ max]``, each filter's largest RMSE ratio ``max_{σ, i} š_i/s_i`` per α, with ν of the ISL filters from
``recommend_nu`` over the same range.

Choices: the extra filters ride on the displayed run (one ``simulate`` call, common random numbers); the
model-aware ISL filter uses the same ν as paper A's filter (the ν slider); σ̄ of the mismatched filter is
``sigma_design``; the minimax and adaptive filters use ``[sigma_min, sigma_max]``. The worst-case table uses
the current m, w and seed. Their inputs live in the session's rooms :class:`app.state.BaselinesRoom` and
:class:`app.state.WorstCaseRoom`; this module holds the functions those rooms and the run pipeline call.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

from isl_core import (
    BASELINES,
    BOUNDS,
    SIGMA_RANGE,  # the plausible σ range a page opens with
    Candidates,
    Execution,
    Model,
    Sampling,
    WorstCaseTable,
    baseline_filters,
    theory_ratios,
    worst_case,
)

__all__ = [
    "ALPHA_BOUNDS",
    "EXTRA_NAMES",
    "SIGMA_BOUNDS",
    "SIGMA_DESIGN",
    "SIGMA_RANGE",
    "check_order",
    "extra_specs",
    "extra_theory",
    "worst_case_table",
]

EXTRA_NAMES = tuple(n for n in BASELINES if n not in ("kbf", "isl"))  #: filters a user can overlay
SIGMA_BOUNDS = BOUNDS.sigma.range  #: the σ inputs of the extra filters and the worst case: the dashboard's σ range
SIGMA_DESIGN = 20.0
ALPHA_BOUNDS = (0.001, 100.0)
log = logging.getLogger(__name__)
WC_WORKERS = 1  #: threads of one worst-case computation (it runs on the long-job thread: one core, low priority)


def extra_specs(
    model: Model, nu: float, names: Sequence[str], sigma_design: float, sigma_range: tuple[float, float]
) -> list:
    """FilterSpecs of the extra filters ``names`` (none: ``[]``); the model-aware ISL filter shares ``nu``."""
    if not names:
        return []
    return baseline_filters(
        model, nu=nu, nu_model=nu, sigma_design=sigma_design, sigma_range=sigma_range, names=tuple(names)
    )


def extra_theory(model: Model, specs: Sequence) -> dict[str, np.ndarray]:
    """Predicted ratios per extra filter (Lyapunov / :ref:`linearization`; nan for the adaptive filter)."""
    return {spec.name: np.asarray(theory_ratios(model, spec)) for spec in specs}


def worst_case_table(
    alphas: Sequence[float],
    *,
    sigma_range: tuple[float, float],
    n_sigma: int,
    m: int,
    w: float,
    sigma_design: float,
    horizon: float,
    seed: int,
    progress=None,
) -> WorstCaseTable:
    """:func:`isl_core.worst_case` for every filter with one seed and 10 batches (the dashboard's settings)."""
    return worst_case(
        list(alphas),
        sigma_range=sigma_range,
        n_sigma=n_sigma,
        m=m,
        w=w,
        candidates=Candidates(sigma_design=sigma_design),
        sampling=Sampling((seed,), horizon, batches=10),
        execution=Execution(workers=WC_WORKERS, progress=progress),
    )


def check_order(sigma_min: float, sigma_max: float) -> None:
    """The σ range must be a range: ``ValueError`` in words otherwise."""
    if not sigma_min < sigma_max:
        raise ValueError(f"σ min (sigma_min) must be below σ max (sigma_max); {sigma_min:g} is not below {sigma_max:g}")
