"""The dashboard's baselines: extra filters on the same run, and the worst case over an unknown σ.

A user who does not know σ could run, instead of the ISL filter, a Kalman–Bucy filter designed for a guessed
σ̄ ("mismatched"), one designed for the top of the plausible σ range ("minimax"), an adaptive one that
estimates σ online, or the model-aware ISL filter that propagates with A = A0 − αEEᵀ (:mod:`isl_core.baselines`).
:class:`Baselines` declares the inputs for them (bounds, label, doc), and the worst-case comparison of
:func:`isl_core.worst_case`: for the σ range ``[sigma_min, sigma_max]``, each filter's largest RMSE ratio
``max_{σ, i} š_i/s_i`` per α, with ν of the ISL filters from ``recommend_nu`` over the same range.

Choices: the extra filters ride on the displayed run (one ``simulate`` call, common random numbers); the
model-aware ISL filter uses the same ν as paper A's filter (the ν slider); σ̄ of the mismatched filter is
``sigma_design``; the minimax and adaptive filters use ``[sigma_min, sigma_max]``. The worst-case table uses
the current m, w and seed. :class:`app.state.AppState` inherits these inputs and methods.
"""
from __future__ import annotations

import logging
from collections.abc import Sequence
from functools import partial

import numpy as np
import param

from isl_core import BASELINES, Model, WorstCaseTable, baseline_filters, theory_ratios, worst_case
from isl_core.filters.baselines import LABELS
from isl_core.sweep import BURN
from isl_core.worstcase import FILTERS

from .text import R_MIN, per_r_min

__all__ = ["EXTRA_NAMES", "INPUTS", "RUN_INPUTS", "WC_INPUTS", "Baselines", "check_order", "extra_specs",
           "extra_theory", "worst_case_table"]

EXTRA_NAMES = tuple(n for n in BASELINES if n not in ("kbf", "isl"))  #: filters a user can overlay
RUN_INPUTS = ("extra_filters", "sigma_design", "sigma_min", "sigma_max")  #: change the displayed run
WC_INPUTS = ("wc_alphas", "wc_n_sigma", "wc_horizon")  #: change only the worst-case table
INPUTS = RUN_INPUTS + WC_INPUTS
SIGMA_BOUNDS = (0.1, 1000.0)
ALPHA_BOUNDS = (0.001, 100.0)
log = logging.getLogger(__name__)
WC_WORKERS = 1  #: threads of one worst-case computation (it runs on the long-job thread: one core, low priority)


def extra_specs(model: Model, nu: float, names: Sequence[str], sigma_design: float,
                sigma_range: tuple[float, float]) -> list:
    """FilterSpecs of the extra filters ``names`` (none: ``[]``); the model-aware ISL filter shares ``nu``."""
    if not names:
        return []
    return baseline_filters(model, nu=nu, nu_model=nu, sigma_design=sigma_design, sigma_range=sigma_range,
                            names=tuple(names))


def extra_theory(model: Model, specs: Sequence) -> dict[str, np.ndarray]:
    """Predicted ratios per extra filter (Lyapunov / SPEC §6; nan for the adaptive filter)."""
    return {spec.name: np.asarray(theory_ratios(model, spec)) for spec in specs}


def worst_case_table(alphas: Sequence[float], *, sigma_range: tuple[float, float], n_sigma: int, m: int, w: float,
                     sigma_design: float, horizon: float, seed: int, progress=None) -> WorstCaseTable:
    """:func:`isl_core.worst_case` for every filter with one seed and 10 batches (the dashboard's settings)."""
    return worst_case(list(alphas), sigma_range=sigma_range, n_sigma=n_sigma, m=m, w=w, sigma_design=sigma_design,
                      horizon=horizon, seeds=(seed,), batches=10, workers=WC_WORKERS, progress=progress)


def check_order(sigma_min: float, sigma_max: float) -> None:
    """The σ range must be a range: ``ValueError`` in words otherwise."""
    if not sigma_min < sigma_max:
        raise ValueError(f"σ min (sigma_min) must be below σ max (sigma_max); {sigma_min:g} is not below "
                         f"{sigma_max:g}")


class Baselines(param.Parameterized):
    """Inputs and outputs of the extra filters and the worst-case table (module docstring).

    Expects the host class to provide ``_jobs`` (:class:`app.jobs.Jobs`), ``m``, ``w``, ``seed``.
    """

    extra_filters = param.ListSelector(default=[], objects=list(EXTRA_NAMES), label="extra filters", doc=(
        "Baselines drawn on the same run (same noise): " + ", ".join(LABELS[n] for n in EXTRA_NAMES) + "."))
    sigma_design = param.Number(20.0, bounds=SIGMA_BOUNDS, label="σ̄ of the KBF for mid σ", doc=(
        "The σ the mismatched Kalman–Bucy filter is designed for (its gain solves the CARE, A.23, at σ̄)."))
    sigma_min = param.Number(2.0, bounds=SIGMA_BOUNDS, label="σ min", doc=(
        "Bottom of the plausible σ range (below σ max): the adaptive filter's table, the worst-case table."))
    sigma_max = param.Number(200.0, bounds=SIGMA_BOUNDS, label="σ max", doc=(
        "Top of the plausible σ range (above σ min): the minimax Kalman–Bucy filter is designed for it."))
    wc_alphas = param.List([0.04, 0.2, 1.0, 5.0, 25.0], item_type=float, bounds=(1, 5), label="α values", doc=(
        "Rows of the worst-case table: 1 to 5 values of α in [0.001, 100]; paper A, Fig. 2: 0.04 … 25."))
    wc_n_sigma = param.Integer(5, bounds=(2, 11), label="σ grid points", doc=(
        "Log-spaced σ values (both ends included) over which each worst case is taken."))
    wc_horizon = param.Number(100.0, bounds=(20.0, 2000.0), label=f"worst-case horizon (× 1/{R_MIN})", doc=(
        f"Length of each simulated run of the worst-case table in units of 1/{R_MIN}; ±2 % needs about 1000."))

    extra_prediction = param.Dict(default={}, precedence=-1, doc="Predicted ratios of the run's extra filters.")
    worst = param.ClassSelector(class_=WorstCaseTable, default=None, allow_None=True, precedence=-1)
    worst_busy = param.Boolean(False, precedence=-1)
    worst_progress = param.Number(0.0, bounds=(0.0, 1.0), precedence=-1)
    worst_note = param.String("", precedence=-1, doc="Status line of the worst-case table.")

    @property
    def sigma_range(self) -> tuple[float, float]:
        return self.sigma_min, self.sigma_max

    def compute_worst_case(self) -> None:
        """Simulate the worst-case table as the session's long job (progress in ``worst_progress``; cancellable)."""
        if blocked := self.refused_among((*WC_INPUTS, "sigma_min", "sigma_max", "sigma_design")):
            self.worst_note = blocked
            return
        fn = partial(worst_case_table, tuple(self.wc_alphas), sigma_range=self.sigma_range, n_sigma=self.wc_n_sigma,
                     m=self.m, w=self.w, sigma_design=self.sigma_design, horizon=self.wc_horizon, seed=self.seed)
        self._worst_task.start(fn, self._apply_worst, (
            f"Simulating {len(self.wc_alphas)} α × {self.wc_n_sigma} σ, {len(FILTERS)} filters on each run …"))

    def cancel_worst_case(self) -> None:
        """Stop the worst-case computation: dropped if it waits in the queue, else ended (see LongTask.cancel)."""
        self._worst_task.cancel()

    def _apply_worst(self, outcome) -> None:
        """Show a computed worst-case table and where its numbers come from."""
        t: WorstCaseTable = outcome.value
        lo, hi = t.sigma_range
        k_lo, k_hi = float(t.stretch.min()), float(t.stretch.max())
        longer = "" if k_hi == 1.0 else (f", both lengthened ×{k_lo:.3g}–×{k_hi:.3g} where a filter settles slower "
                                         "than the optimal one (B.46)")
        self.param.update(worst=t, worst_note=(
            f"Simulated in {outcome.seconds:.1f} s: σ ∈ [{lo:g}, {hi:g}] ({len(t.sigmas)} values), m = {t.m}, "
            f"w = {t.w:g}, seed {t.seeds[0]}. Each run averages over {per_r_min(t.horizon)} after a burn-in of "
            f"{per_r_min(BURN)}{longer}; 95 % batch-means intervals."))
