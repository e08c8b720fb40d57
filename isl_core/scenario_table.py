"""Who wins where: every filter's worst-case ratio to the clairvoyant reference, per scenario (issue: "beyond σ").

:func:`scenario_table` simulates each scenario of :data:`PRESETS` (or any given) with ``seeds`` independent noises
and, per filter, reports the **worst-case ratio**: the largest, over time windows of ``window``/r_min and over the
coordinates, of

    √( mean over seeds of the window's mean squared error / the window's mean clairvoyant variance P_ii )

leaving out the first ``burn``/r_min (the start from each filter's own guess, which a user can choose; the σ steps
of the presets come later, at 10/r_min). Averaging over seeds before the maximum keeps the maximum from picking a
single unlucky window, but a maximum of noisy estimates still lies above the maximum of their means (the
clairvoyant filter's own worst case, truly 1, comes out ≈ 1.1 with 64 seeds). The interval is the *basic* bootstrap
over the seeds, [2θ̂ − q_high, 2θ̂ − q_low] with q the bootstrap quantiles at ``level``: it moves down by the bias
that resampling shows (a percentile interval would sit wholly above θ̂ and above the truth). With the default 64
seeds the clairvoyant row's interval contains 1 in every preset; with a handful of seeds the bias is larger than
resampling shows, and the clairvoyant row says so. Times are in units of 1/r_min of the model at σ(0).

Filters (rows): the Kalman–Bucy filter optimal for σ(0) ("optimal for constant σ"), the adaptive filter
(:mod:`isl_core.adaptive`), the variational-Bayes filter (:mod:`isl_core.variational`), the robust filter
(:mod:`isl_core.robust`), the ISL filter at table (A.31)'s ν for this α (paper A's value, when the table has this α),
the ISL filter at the minimax ν of :func:`isl_core.recommend_nu` (theory over σ ∈ {2, 20, 200}) and the model-aware
ISL filter at its own minimax ν. The σ-learning filters start from the geometric middle of [2, 200], σ̂ = 20, as the
adaptive filter's default. The clairvoyant filter itself is the first row: ≈ 1 up to sampling error, the check.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from .adaptive import adaptive_kbf
from .baselines import model_aware_isl
from .filters import isl_filter
from .model import Model
from .paper import M, W, a31_nu_over_beta
from .recommend import recommend_nu
from .robust import robust_kbf
from .scenario import Scenario
from .scenario_average import BOOT_SEED, average_scenario, worst_ratio
from .validate import check_int, check_real
from .variational import variational_kbf

__all__ = ["PRESETS", "ScenarioTable", "scenario_table"]

SIGMA_RANGE = (2.0, 200.0)  #: the σ range the σ-learning filters' tables and the minimax ν are built for
#: name: (label, σ(0), scenario)
PRESETS: Mapping[str, tuple[str, float, Scenario]] = {
    "sigma_drop": ("σ 200 → 2 at 10/r_min", 200.0, Scenario(sigma_knots=((10.0, 2.0),))),
    "sigma_rise": ("σ 2 → 200 at 10/r_min", 2.0, Scenario(sigma_knots=((10.0, 200.0),))),
    "student3": ("Student-t noise, 3 degrees of freedom", 20.0, Scenario(noise="student", dof=3.0)),
    "outliers": ("1 % outliers × 30", 20.0, Scenario(noise="outliers", outlier_rate=0.01, outlier_scale=30.0)),
    "sensor": ("sensor read every 0.1/r_min", 20.0, Scenario(sensor_interval=0.1)),
    "constant": ("constant σ, Gaussian", 20.0, Scenario()),
}


@dataclass(frozen=True)
class ScenarioTable:
    """``worst[f, s]`` with the interval ``low``/``high`` (basic bootstrap, module docstring); rows ``filters``
    (names), ``labels``; columns ``scenarios`` (preset names) with ``scenario_labels``; ``winner[s]`` the filter (name)
    with the lowest worst case but the clairvoyant one, ``margin[s]`` the runner-up's worst case over the
    winner's, ``margin_low[s]`` its lower bound (paired bootstrap over the seeds,
    :func:`isl_core.scenario_average.margin_low`) and ``tie[s]`` whether that bound is ≤ 1: the seeds cannot tell
    the winner from the runner-up."""

    alpha: float
    m: int
    w: float
    filters: tuple[str, ...]
    labels: tuple[str, ...]
    scenarios: tuple[str, ...]
    scenario_labels: tuple[str, ...]
    worst: np.ndarray
    low: np.ndarray
    high: np.ndarray
    seeds: int
    horizon: float
    window: float
    burn: float
    level: float
    margin_low: np.ndarray

    @property
    def winner(self) -> tuple[str, ...]:
        return tuple(self.filters[1 + int(np.argmin(col))] for col in self.worst[1:].T)

    @property
    def runner_up(self) -> tuple[str, ...]:
        return tuple(self.filters[1 + int(np.argsort(col)[1])] for col in self.worst[1:].T)

    @property
    def tie(self) -> np.ndarray:
        return self.margin_low <= 1.0

    @property
    def margin(self) -> np.ndarray:
        ranked = np.sort(self.worst[1:], axis=0)
        return ranked[1] / ranked[0]


def _filters(model: Model, alpha: float, m: int, w: float):
    """The table's filters for one model (the run carries the clairvoyant, σ(0)-optimal and first ISL filters)."""
    beta = model.beta
    nob = a31_nu_over_beta(alpha, m, w)
    minimax = recommend_nu(alpha, sigmas=(2.0, 20.0, 200.0), m=m, w=w, verify=False).nu
    aware = recommend_nu(alpha, sigmas=(2.0, 20.0, 200.0), m=m, w=w, verify=False, model_aware=True).nu
    guess = math.sqrt(SIGMA_RANGE[0] * SIGMA_RANGE[1])
    first = beta * nob if nob is not None else minimax
    extra = [adaptive_kbf(model, sigma_range=SIGMA_RANGE, sigma_init=guess),
             variational_kbf(model, sigma_init=guess),
             robust_kbf(model, sigma_range=SIGMA_RANGE, sigma_init=guess)]
    if nob is not None:
        extra.append(dataclasses.replace(isl_filter(model, minimax), name="isl_minimax",
                                         label=f"ISL, minimax ν = {minimax:.3g}"))
    extra.append(model_aware_isl(model, aware))
    first_label = (f"ISL, table (A.31) ν = {first:.3g}" if nob is not None else f"ISL, minimax ν = {first:.3g}")
    return first, first_label, extra


def table_labels(run, nu_label: str) -> tuple[str, ...]:
    """Row labels: the run's, with the σ(0)-optimal filter named without its σ(0) and the first ISL row's tuning."""
    return (run.labels[0], "Kalman–Bucy for constant σ = σ(0)", nu_label, *run.labels[3:])


def scenario_table(
    alpha: float = 1.0,
    *,
    m: int = M,
    w: float = W,
    scenarios: Mapping[str, tuple[str, float, Scenario]] = PRESETS,
    seeds: int = 64,
    horizon: float = 30.0,
    window: float = 1.0,
    burn: float = 2.0,
    level: float = 0.95,
    progress: Callable[[float], None] | None = None,
) -> ScenarioTable:
    """The worst-case table (module docstring) for paper A's model with this α (β = w√(2α), A.25)."""
    alpha = check_real("alpha", alpha, lo=0.0, lo_open=True)
    seeds = check_int("seeds", seeds, lo=2, hi=10_000)
    horizon = check_real("horizon", horizon, lo=0.0, lo_open=True)
    window = check_real("window", window, lo=0.0, lo_open=True, hi=horizon)
    burn = check_real("burn", burn, lo=0.0, hi=horizon, hi_open=True)
    level = check_real("level", level, lo=0.5, hi=1.0, hi_open=True)
    windows = max(1, round(horizon / window))
    worst, low, high, lows, names, labels = [], [], [], [], None, None
    rng = np.random.default_rng(BOOT_SEED)
    for j, (_, sigma0, scenario) in enumerate(scenarios.values()):
        model = Model.from_w(alpha, w, sigma0, m)
        nu, nu_label, extra = _filters(model, alpha, m, w)
        avg = average_scenario(model, nu, scenario, seeds=range(seeds), horizon=horizon, windows=windows, extra=extra,
                               progress=progress, done=j * seeds, total=len(scenarios) * seeds)
        run = avg.run
        if names is None:
            names, labels = run.names, table_labels(run, nu_label)
        keep = run.starts_after(burn)
        point, lo, hi, margin = worst_ratio(avg.mse[:, keep], run.ref_var[keep], level, rng, margin=True)
        worst.append(point)
        low.append(lo)
        high.append(hi)
        lows.append(margin)
    return ScenarioTable(alpha, m, w, names, labels, tuple(scenarios), tuple(v[0] for v in scenarios.values()),
                         np.array(worst).T, np.array(low).T, np.array(high).T, seeds, horizon, window, burn, level,
                         np.array(lows))
