"""isl_core — Kalman–Bucy vs the inverse-statistical-linearization (ISL) filter.

Numerical core of the ``isl`` project: the model (A.1–A.6), the stationary Kalman–Bucy filter (A.21–A.24),
the ISL filter (A.16–A.18), a compiled simulator of both on one Euler grid (B.30–B.34), and every filter over a
recorded series with the model fitted to it (:mod:`!isl_core.series`).
Imports numpy, scipy and numba only — never a UI library.
"""

__version__ = "0.2.0"  #: the project's one version string (pyproject.toml reads it; ``isl --version`` prints it)

from .filters import (
    BASELINES,
    AdaptiveGain,
    FilterSpec,
    adaptive_kbf,
    baseline_filters,
    imm_kbf,
    isl_filter,
    linearized_matrix,
    mismatched_kbf,
    optimal_kbf,
    robust_kbf,
    variational_kbf,
)
from .grid import RunPlan, run_plan, settling_rate, step_size
from .model import M_MAX, Model
from .nonlinearity import gamma_abs, isl_exponents, isl_gains, linearization, phi
from .recommend import Recommendation, recommend_nu
from .riccati import G_matrix, KalmanBucy, care_residual, kalman_bucy, kalman_bucy_alpha0
from .rmse import RmseResult, simulate_rmse
from .scenario import (
    FAMILIES,
    Clairvoyant,
    Costs,
    Period,
    PeriodRatios,
    Rolling,
    Scenario,
    ScenarioAverage,
    ScenarioPlan,
    ScenarioRun,
    ScenarioTable,
    TableRow,
    Tuning,
    TuningGrids,
    WhoWinsMap,
    average_scenario,
    clairvoyant,
    filter_costs,
    paired_margin,
    period_ratios,
    plan_scenario,
    scenario_grid,
    scenario_periods,
    scenario_table,
    simulate_scenario,
    table_from,
    tune,
    who_wins_map,
)
from .series import (
    Diagnostics,
    Fit,
    Judgement,
    ReadingModel,
    Series,
    SeriesRun,
    SeriesTrack,
    judge,
    run_filters,
    select_order,
)
from .simulate import DivergenceError, Run, Track, simulate
from .sweep import SweepResult, sweep
from .theory import (
    mismatched_kbf_ratios,
    predicted_covariance,
    predicted_ratios,
    predicted_ratios_grid,
    theory_ratios,
)
from .worstcase import WorstCaseTable, worst_case

__all__ = [
    "BASELINES",
    "FAMILIES",
    "M_MAX",
    "AdaptiveGain",
    "Clairvoyant",
    "Costs",
    "Diagnostics",
    "DivergenceError",
    "FilterSpec",
    "Fit",
    "G_matrix",
    "Judgement",
    "KalmanBucy",
    "Model",
    "Period",
    "PeriodRatios",
    "ReadingModel",
    "Recommendation",
    "RmseResult",
    "Rolling",
    "Run",
    "RunPlan",
    "Scenario",
    "ScenarioAverage",
    "ScenarioPlan",
    "ScenarioRun",
    "ScenarioTable",
    "Series",
    "SeriesRun",
    "SeriesTrack",
    "SweepResult",
    "TableRow",
    "Track",
    "Tuning",
    "TuningGrids",
    "WhoWinsMap",
    "WorstCaseTable",
    "__version__",
    "adaptive_kbf",
    "average_scenario",
    "baseline_filters",
    "care_residual",
    "clairvoyant",
    "clear_caches",
    "filter_costs",
    "gamma_abs",
    "imm_kbf",
    "isl_exponents",
    "isl_filter",
    "isl_gains",
    "judge",
    "kalman_bucy",
    "kalman_bucy_alpha0",
    "linearization",
    "linearized_matrix",
    "mismatched_kbf",
    "mismatched_kbf_ratios",
    "optimal_kbf",
    "paired_margin",
    "period_ratios",
    "phi",
    "plan_scenario",
    "predicted_covariance",
    "predicted_ratios",
    "predicted_ratios_grid",
    "recommend_nu",
    "robust_kbf",
    "run_filters",
    "run_plan",
    "scenario_grid",
    "scenario_periods",
    "scenario_table",
    "select_order",
    "settling_rate",
    "simulate",
    "simulate_rmse",
    "simulate_scenario",
    "step_size",
    "sweep",
    "table_from",
    "theory_ratios",
    "tune",
    "variational_kbf",
    "who_wins_map",
    "worst_case",
]


def clear_caches() -> None:
    """Forget the core's cached solutions (normalized CAREs, Kalman–Bucy filters, adaptive gain tables, ISL
    moments): each is recomputed when next needed. A server calls it when its sessions have ended, so that what a
    class computed does not stay in memory (and pin the allocator's arenas it lies in).

    Examples
    --------
    A solution is computed once and then shared; after ``clear_caches`` it is computed afresh:

    >>> import isl_core
    >>> model = isl_core.Model.from_w(0.5, 3.0, 20.0)
    >>> solved = isl_core.kalman_bucy(model)
    >>> isl_core.kalman_bucy(model) is solved
    True
    >>> isl_core.clear_caches()
    >>> isl_core.kalman_bucy(model) is solved
    False
    """
    from . import nonlinearity, riccati
    from .filters import adaptive

    for cached in (riccati.normalized_care, riccati._solved, adaptive._table, nonlinearity.gamma_moments):
        cached.cache_clear()
