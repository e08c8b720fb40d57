"""isl_core — Kalman–Bucy vs the inverse-statistical-linearization (ISL) filter.

Numerical core of the ``isl`` project: the model (A.1–A.6), the stationary Kalman–Bucy filter (A.21–A.24),
the ISL filter (A.16–A.18), a compiled simulator of both on one Euler grid (B.30–B.34), and every filter over a
recorded series with the model fitted to it (:mod:`!isl_core.series`).
Imports numpy, scipy and numba only — never a UI library.
"""

__version__ = "0.2.0"  #: the project's one version string (pyproject.toml reads it; ``isl --version`` prints it)

from .bounds import BOUNDS, Bound
from .decimate import DISPLAY_POINTS, minmax_indices
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
from .filters.base import SIGMA_RANGE
from .filters.baselines import LABELS as FILTER_LABELS
from .filters.isl import model_aware_isl
from .grid import RunPlan, run_plan, settling_rate, step_size
from .jobs import Cancelled
from .model import M_MAX, Model
from .nonlinearity import gamma_abs, isl_exponents, isl_gains, linearization, phi
from .paper import FIG2_ALPHAS, FIG2_NU_OVER_BETA, FIG2_SIGMAS, PAPER_A, PAPER_B, a31_nu_over_beta
from .recommend import Recommendation, recommend_nu
from .requests import SWEEP_BURN, Execution, Sampling
from .riccati import G_matrix, KalmanBucy, care_residual, kalman_bucy, kalman_bucy_alpha0
from .rmse import RmseResult, simulate_rmse
from .runview import TUBE_THEORY, RunView, simulate_view
from .scenario import (
    FAMILIES,
    MAPS,
    NOISE_LAWS,
    TUNING_SAMPLING,
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
from .scenario.cells import CellStats
from .scenario.heldout import held_out
from .scenario.map import AXIS_LABELS, STEP_AT
from .scenario.presets import DEFAULT_RATE
from .scenario.shipped import ShippedTuning, shipped_json, shipped_tuning, why_not_shipped
from .scenario.table import PRESETS as SCENARIO_PRESETS
from .scenario.table import beyond_rows, beyond_stats, knob_text
from .scenario.variants import paper_nu
from .series import (
    SERIES_FILTERS,
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
from .series.run import sigma_range as series_sigma_range
from .series.sources import DATASETS, csv_columns, dataset, read_csv
from .series.sources import MAX_ROWS as MAX_CSV_ROWS
from .simulate import DivergenceError, Run, Track, simulate
from .sweep import SweepResult, sweep
from .theory import (
    mismatched_kbf_ratios,
    predicted_covariance,
    predicted_ratios,
    predicted_ratios_grid,
    theory_ratios,
)
from .validate import NOT_FINITE, read_int, read_real
from .worstcase import WORST_CASE_FILTERS, WORST_CASE_LABELS, Candidates, WorstCaseTable, worst_case

__all__ = [
    "AXIS_LABELS",
    "BASELINES",
    "BOUNDS",
    "DATASETS",
    "DEFAULT_RATE",
    "DISPLAY_POINTS",
    "FAMILIES",
    "FIG2_ALPHAS",
    "FIG2_NU_OVER_BETA",
    "FIG2_SIGMAS",
    "FILTER_LABELS",
    "MAPS",
    "MAX_CSV_ROWS",
    "M_MAX",
    "NOISE_LAWS",
    "NOT_FINITE",
    "PAPER_A",
    "PAPER_B",
    "SCENARIO_PRESETS",
    "SERIES_FILTERS",
    "SIGMA_RANGE",
    "STEP_AT",
    "SWEEP_BURN",
    "TUBE_THEORY",
    "TUNING_SAMPLING",
    "WORST_CASE_FILTERS",
    "WORST_CASE_LABELS",
    "AdaptiveGain",
    "Bound",
    "Cancelled",
    "Candidates",
    "CellStats",
    "Clairvoyant",
    "Costs",
    "Diagnostics",
    "DivergenceError",
    "Execution",
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
    "RunView",
    "Sampling",
    "Scenario",
    "ScenarioAverage",
    "ScenarioPlan",
    "ScenarioRun",
    "ScenarioTable",
    "Series",
    "SeriesRun",
    "SeriesTrack",
    "ShippedTuning",
    "SweepResult",
    "TableRow",
    "Track",
    "Tuning",
    "TuningGrids",
    "WhoWinsMap",
    "WorstCaseTable",
    "__version__",
    "a31_nu_over_beta",
    "adaptive_kbf",
    "average_scenario",
    "baseline_filters",
    "beyond_rows",
    "beyond_stats",
    "care_residual",
    "clairvoyant",
    "clear_caches",
    "csv_columns",
    "dataset",
    "filter_costs",
    "gamma_abs",
    "held_out",
    "imm_kbf",
    "isl_exponents",
    "isl_filter",
    "isl_gains",
    "judge",
    "kalman_bucy",
    "kalman_bucy_alpha0",
    "knob_text",
    "linearization",
    "linearized_matrix",
    "minmax_indices",
    "mismatched_kbf",
    "mismatched_kbf_ratios",
    "model_aware_isl",
    "optimal_kbf",
    "paired_margin",
    "paper_nu",
    "period_ratios",
    "phi",
    "plan_scenario",
    "predicted_covariance",
    "predicted_ratios",
    "predicted_ratios_grid",
    "read_csv",
    "read_int",
    "read_real",
    "recommend_nu",
    "robust_kbf",
    "run_filters",
    "run_plan",
    "scenario_grid",
    "scenario_periods",
    "scenario_table",
    "select_order",
    "series_sigma_range",
    "settling_rate",
    "shipped_json",
    "shipped_tuning",
    "simulate",
    "simulate_rmse",
    "simulate_scenario",
    "simulate_view",
    "step_size",
    "sweep",
    "table_from",
    "theory_ratios",
    "tune",
    "variational_kbf",
    "who_wins_map",
    "why_not_shipped",
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
