"""Simulate a scenario (:class:`isl_core.scenario.Scenario`): every filter against the clairvoyant reference, in time.

:func:`simulate_scenario` runs the truth, the clairvoyant filter (first), the Kalman–Bucy filter that is optimal
for σ(0) (second), the ISL filter with tuning ν and any ``extra`` filters on one grid with one noise (compiled loop:
:func:`isl_core.kernels.scenario.advance_scenario`). It keeps, per time window, each filter's mean squared error and
the clairvoyant filter's mean exact variance P_ii, so that

    ratio_f,i(window) = √(mean e_f,i² / mean P_ii)                                              (:ref:`rolling-ratio`)

is the time-resolved picture, and the same over the whole run after ``burn`` the summary. The clairvoyant filter's
own ratio is ≈ 1 in every scenario (its P is exact on the grid): that is the check that the denominator is right.

Grid: h is the smallest step :func:`isl_core.grid.run_plan` gives for the model at σ(0), at the smallest and at the
largest σ of the path (a drop of σ speeds every filter up: the step must follow the fastest); a sensor reads every
q ≥ 1 steps, h then Δ/q exactly, and ``refine`` halves h below that on the same path of the noise
(:func:`isl_core.scenario.grid.scenario_grid`). T = ``horizon`` in units of 1/r_min at σ(0). The start is that of
:func:`isl_core.simulate.simulate` (``"stationary"``): every filter at X(0) − e₀, e₀ ~ N(0, Δ) at σ(0) — the
clairvoyant filter's P_0. With the default scenario the Kalman–Bucy and ISL filters' errors are those of
:func:`isl_core.simulate.simulate` with the same seed, bit for bit at every step (same grid, same draws, same
arithmetic; a test compares every step's squared error with one window per step).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import cast

import numpy as np

from .._engine import CHUNK, DivergenceError, draw_start, pack
from ..filters.base import KIND_CLAIRVOYANT, FilterSpec
from ..filters.isl import isl_filter
from ..filters.kalman import optimal_kbf
from ..grid import check_filters, check_specs
from ..kernels.bundles import ClairvoyantState, FilterBank, FilterState, Grid, IMMState, Observation, Windows
from ..kernels.clairvoyant import clairvoyant_state
from ..kernels.imm import imm_state
from ..kernels.scenario import advance_scenario
from ..model import Model
from ..riccati import kalman_bucy
from ..validate import check_int, check_real
from .base import Scenario
from .grid import MAX_SCENARIO_STEPS, scenario_grid
from .learners import learning_state, learns_sigma
from .windows import first_step, memory_time, window_edges, window_times

__all__ = [
    "MAX_SCENARIO_STEPS",
    "ScenarioPlan",
    "ScenarioRun",
    "first_step",
    "memory_time",
    "plan_scenario",
    "scenario_grid",
    "simulate_scenario",
]


@dataclass(frozen=True)
class ScenarioRun:
    """Windowed figures of one scenario run. Filters in order: ``names`` / ``labels`` (clairvoyant first).

    ``t`` (nw + 1,) window edges; ``mse`` (nw, nf, m) mean squared error per window; ``ref_var`` (nw, m) mean of the
    clairvoyant P_ii per window; ``sigma`` (nw,) mean σ_k; ``sigma_hat`` (nw, na) mean σ̂ of the σ-learning filters;
    ``diverged[f]`` the time a filter's error left the finite numbers (None: it did not) — from that window on its
    ``mse`` is inf and its σ̂ nan, and the other filters' figures are unaffected.
    """

    model: Model
    scenario: Scenario
    nu: float
    seed: int
    h: float
    N: int
    q: int
    r_min: float
    names: tuple[str, ...]
    labels: tuple[str, ...]
    t: np.ndarray
    mse: np.ndarray
    ref_var: np.ndarray
    sigma: np.ndarray
    sigma_hat: np.ndarray
    steps: np.ndarray
    diverged: tuple[float | None, ...] = ()
    learning: tuple[str, ...] = ()

    def memory_time(self, memory: float) -> float:
        """W = ``memory`` sensor readings as a time in units of 1/r_min at σ(0): W·q·h·r_min
        (:mod:`!isl_core.filters.adaptive`)."""
        return memory_time(memory, self.q, self.h, self.r_min)

    def starts_after(self, burn: float) -> np.ndarray:
        """Which windows start at or after ``burn`` (units of 1/r_min at σ(0)), per window (nw,)."""
        return self.t[:-1] * self.r_min >= burn - 1e-12

    def ratios(self) -> np.ndarray:
        """√(mse / ref_var) per window, filter and coordinate (nw, nf, m)."""
        return cast("np.ndarray", np.sqrt(self.mse / self.ref_var[:, None, :]))

    def overall(self, burn: float = 0.0) -> np.ndarray:
        """The ratio over the windows that start at or after ``burn`` (units of 1/r_min at σ(0)), per filter and
        coordinate (nf, m): RMSE over the mean clairvoyant variance, both weighted by the windows' steps."""
        keep = self.starts_after(burn)
        if not np.any(keep):
            raise ValueError(f"burn = {burn:g} leaves no window of a run of {self.t[-1] * self.r_min:g}/r_min")
        w = self.steps[keep].astype(float)
        mse = np.tensordot(w, self.mse[keep], axes=1) / w.sum()
        ref = np.tensordot(w, self.ref_var[keep], axes=1) / w.sum()
        return cast("np.ndarray", np.sqrt(mse / ref[None, :]))


@dataclass(frozen=True)
class ScenarioPlan:
    """What every seed's run of one scenario shares (:func:`plan_scenario`): the grid, the filters packed for the
    loop and their start; :meth:`run` is one seed's run. Its arrays are copied for each run, never written."""

    model: Model
    scenario: Scenario
    nu: float
    h: float
    N: int
    q: int
    r_min: float
    edges: np.ndarray
    filters: tuple[FilterSpec, ...]
    packed: FilterBank
    learning_state: tuple[np.ndarray, np.ndarray, np.ndarray]
    delta: np.ndarray
    imm: IMMState
    refine: int = 0

    def memory_time(self, memory: float) -> float:
        """W = ``memory`` sensor readings as a time in units of 1/r_min at σ(0): W·q·h·r_min
        (:mod:`!isl_core.filters.adaptive`)."""
        return memory_time(memory, self.q, self.h, self.r_min)

    def run(self, seed: int = 0, progress: Callable[[float], None] | None = None) -> ScenarioRun:
        """The run with noise from ``seed`` (module docstring); ``progress`` gets the fraction of steps done."""
        seed = check_int("seed", seed, lo=0)
        model, nf, nw = self.model, len(self.filters), len(self.edges) - 1
        rng = np.random.default_rng(seed)
        x, e0 = draw_start(model, kalman_bucy(model), rng, "stationary")
        e = np.tile(e0, (nf, 1))
        bank = self.packed._replace(ad=self.packed.ad.copy())  # the σ-learners' state is the run's own
        learning = learns_sigma(bank.kind)
        state = FilterState(np.zeros(nf), np.full(nf, -1, dtype=np.int64), *(a.copy() for a in self.learning_state))
        imm = IMMState(*(a.copy() for a in self.imm))
        imm.e[:] = e0  # every mode of every bank at the common start
        windows = Windows(
            self.edges, np.zeros((nw, nf, model.m)), np.zeros((nw, int(learning.sum()))), np.zeros((nw, model.m + 1))
        )
        clair = clairvoyant_state(self.delta, self.q)  # its P_0: Δ at σ(0)
        bridges = [
            np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(lev,))))
            for lev in range(1, self.refine + 1)
        ]  # the Brownian bridge's normals, one stream per level of refinement
        self._advance(x, e, rng, bank, state, clair, imm, windows, progress, bridges)
        return self._result(seed, windows, state.died, learning)

    def _advance(
        self,
        x: np.ndarray,
        e: np.ndarray,
        rng: np.random.Generator,
        bank: FilterBank,
        state: FilterState,
        clair: ClairvoyantState,
        imm: IMMState,
        windows: Windows,
        progress: Callable[[float], None] | None,
        bridges: Sequence[np.random.Generator] = (),
    ) -> None:
        """The scenario loop over the whole run, chunk by chunk, σ_k of each chunk from the scenario; on a refined
        grid each chunk's bridge normals from ``bridges`` (level ℓ's stream, base step after base step, so that the
        runs refined L and L + 1 times share levels 1 … L)."""
        model, scenario, h, n, r_min = self.model, self.scenario, self.h, self.N, self.r_min
        grid, law = Grid(h, model.alpha, model.beta), scenario.noise_law()
        k = 0
        while k < n:
            todo = min(CHUNK, n - k)
            t0, t1 = k * (h * r_min), (k + todo - 1) * (h * r_min)
            if scenario.sigma_constant_on(t0, t1):  # σ_k = σ(t_k): one value, or one per step
                sig = scenario.sigma_at(model.sigma, np.array([t0]))
            else:
                sig = scenario.sigma_at(model.sigma, np.arange(k, k + todo) * (h * r_min))
            obs = Observation(sig, law, self.q)
            if self.refine:
                base = todo >> self.refine
                bridge = np.concatenate(
                    [g.standard_normal((base, 1 << lev, 2)) for lev, g in enumerate(bridges)], axis=1
                )
                obs = Observation(sig, law, self.q, bridge, self.refine)
            done = advance_scenario(x, e, rng, todo, k, grid, obs, bank, state, clair, imm, windows)
            if done < todo:
                raise DivergenceError(
                    f"the simulated truth diverged at t = {(k + done) * h:.4g} "
                    f"(step {k + done:,} of {n:,}, h = {h:.3g})"
                )
            k += done
            if progress is not None:
                progress(k / n)

    def _result(self, seed: int, windows: Windows, died: np.ndarray, learning: np.ndarray) -> ScenarioRun:
        """The run's windowed figures from the loop's sums; a diverged filter's from its window on are inf (σ̂ nan)."""
        h, edges, filters = self.h, self.edges, self.filters
        steps = np.diff(edges)
        mse, sigma_hat = windows.sq / steps[:, None, None], windows.sigma_hat / steps[:, None]
        slots = np.cumsum(learning) - 1
        for f in np.flatnonzero(died >= 0):  # from its window on, a diverged filter's error is infinite
            w_died = int(np.searchsorted(edges, died[f], side="right")) - 1
            mse[w_died:, f, :] = np.inf
            if learning[f]:
                sigma_hat[w_died:, slots[f]] = np.nan
        # window w holds the errors at t_{k+1} for steps k in [edges[w], edges[w+1]): P_{k+1}; and σ_k
        ref_var, mean_sigma = windows.ref[:, :-1] / steps[:, None], windows.ref[:, -1] / steps
        return ScenarioRun(
            self.model,
            self.scenario,
            self.nu,
            seed,
            h,
            self.N,
            self.q,
            self.r_min,
            tuple(f.name for f in filters),
            tuple(f.label for f in filters),
            edges * h,
            mse,
            ref_var,
            mean_sigma,
            sigma_hat,
            steps,
            tuple(float(d * h) if d >= 0 else None for d in died),
            tuple(f.name for f, a in zip(filters, learning, strict=True) if a),
        )


def plan_scenario(
    model: Model,
    nu: float,
    scenario: Scenario | None = None,
    *,
    horizon: float = 30.0,
    windows: int = 60,
    extra: Sequence[FilterSpec] = (),
    edges: Sequence[float] | None = None,
    grid_filters: Sequence[FilterSpec] | None = None,
    refine: int = 0,
) -> ScenarioPlan:
    """The runs of ``scenario`` (default: paper A's model; module docstring) with ``windows`` equal time windows
    over ``horizon`` (units of 1/r_min at σ(0)), or with windows between the times ``edges`` (0 = edges[0] < … <
    edges[-1] = horizon, e.g. the periods of :mod:`!isl_core.scenario.periods`), checked and set up once for any number
    of seeds. A window starting at time τ starts at the first step k with t_k ≥ τ: the step at which σ(t) takes a
    value that starts at τ (:meth:`Scenario.sigma_at`), so a window that starts at a change of σ holds exactly the
    errors after it. ``grid_filters``: more filters whose rates set the step h (not run), e.g. the others of a set
    of runs that must share one grid.

    Parameters
    ----------
    model, nu, scenario, horizon, windows, extra : Model, float, Scenario, float, int, sequence of FilterSpec
        As in :func:`simulate_scenario`.
    edges : sequence of float, optional
        Window edges instead of ``windows`` equal ones.
    grid_filters : sequence of FilterSpec, optional
        Filters that count for the step size.
    refine : int, default 0
        With a sensor interval, halve the step this many times, on the same path of the noise (:func:`scenario_grid`).

    Returns
    -------
    ScenarioPlan
        ``run(seed)`` gives the :class:`ScenarioRun` of a seed.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import plan_scenario, simulate_scenario
    >>> from isl_core import Model, Scenario
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> rise = Scenario(sigma_knots=((5.0, 40.0),))  # σ doubles at t = 5/r_min
    >>> plan = plan_scenario(model, model.beta, rise, horizon=10.0, windows=5)
    >>> bool(np.array_equal(plan.run(3).mse, simulate_scenario(model, model.beta, rise, horizon=10.0, windows=5,
    ...                                                         seed=3).mse))
    True
    """
    scenario = Scenario() if scenario is None else scenario
    if not isinstance(scenario, Scenario):
        raise ValueError(f"scenario must be an isl_core.Scenario, got {type(scenario).__name__}")
    horizon = check_real("horizon", horizon, lo=0.0, lo_open=True)
    windows = check_int("windows", windows, lo=1, hi=100_000)
    times = window_times(horizon, windows, edges)
    specs = check_filters(model, nu, extra)
    more = check_specs("grid_filters", model, grid_filters or (), allow_empty=True)
    h, n, r_min = scenario_grid(model, nu, scenario, [*specs[1:], *more], horizon, refine)
    kb = kalman_bucy(model)
    clair = FilterSpec(
        "clairvoyant", "Kalman filter that knows σ(t) (clairvoyant)", model.alpha, np.zeros(model.m), False
    )
    constant = dataclasses.replace(optimal_kbf(model, kb), label=f"Kalman–Bucy for constant σ = σ(0) = {model.sigma:g}")
    filters = (clair, constant, isl_filter(model, nu), *specs[1:])
    bank = pack(model, filters, scenario=True)
    bank.kind[0] = KIND_CLAIRVOYANT
    learning = learning_state(model, filters, bank.ad)
    q = scenario.sensor_steps(h, r_min)
    return ScenarioPlan(
        model,
        scenario,
        float(nu),
        h,
        n,
        q,
        r_min,
        window_edges(times, h * r_min, n),
        filters,
        bank,
        learning,
        np.array(kb.delta, dtype=float),
        imm_state(filters, model.m, q, h),
        refine,
    )


def simulate_scenario(
    model: Model,
    nu: float,
    scenario: Scenario | None = None,
    *,
    horizon: float = 30.0,
    windows: int = 60,
    seed: int = 0,
    extra: Sequence[FilterSpec] = (),
    progress: Callable[[float], None] | None = None,
) -> ScenarioRun:
    """One run of ``scenario`` (default: paper A's model; module docstring): ``windows`` equal time windows over
    ``horizon`` (units of 1/r_min at σ(0)). The same as ``plan_scenario(…).run(seed)``.

    Parameters
    ----------
    model : Model
        The model at σ(0).
    nu : float
        The ISL filter's tuning.
    scenario : Scenario, optional
        What the world does (default: paper A's model).
    horizon : float, default 30.0
        Length in units of 1/r_min at σ(0).
    windows : int, default 60
        Equal time windows the errors are averaged over.
    seed : int, default 0
        The noise.
    extra : sequence of FilterSpec
        More filters on the same noise.
    progress : callable, optional
        Called with the fraction done.

    Returns
    -------
    ScenarioRun
        Per window (t), filter and coordinate the mean squared error ``mse`` and the clairvoyant filter's exact
        variance ``ref_var``; :meth:`ScenarioRun.ratios` their ratio.

    Examples
    --------
    >>> from isl_core import simulate_scenario
    >>> from isl_core import Model, Scenario
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> rise = Scenario(sigma_knots=((5.0, 40.0),))  # σ doubles at t = 5/r_min
    >>> run = simulate_scenario(model, model.beta, rise, horizon=10.0, windows=5)
    >>> run.names, run.mse.shape  # windows × filters × coordinates
    (('clairvoyant', 'kbf', 'isl'), (5, 3, 3))
    """
    seed = check_int("seed", seed, lo=0)
    return plan_scenario(model, nu, scenario, horizon=horizon, windows=windows, extra=extra).run(seed, progress)
