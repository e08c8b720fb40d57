"""The dashboard's Scenario group: σ that changes, heavy-tailed noise, a coarse sensor — against a clairvoyant filter.

The model inputs (α, β, m, ν, seed) are the dashboard's; σ is σ(0), where the scenario starts. :class:`ScenarioInputs`
declares the scenario's own inputs (bounds, label, doc; :class:`app.state.AppState` inherits them, so they are
checked, linked in the URL and refused in words like every other input) and computes two things through the core:

* **the picture** (:func:`scenario_picture`): :func:`isl_core.average_scenario` over ``sc_runs`` seeds (the seed
  input and the ones after it), every filter's rolling RMSE ratio to the clairvoyant Kalman filter that knows σ(t)
  (:meth:`isl_core.ScenarioAverage.rolling`), σ(t) and each σ-learning filter's σ̂(t), and each filter's worst case
  over the windows after 2/r_min with its bootstrap interval. A job on the pool of large runs, recomputed when an
  input changes while the tab is open;
* **the who-wins map** (:func:`isl_core.who_wins_map` for the page's α, β and m at σ(0) = 20): the session's long job
  (progress, cancel, place in the queue).

The filters: the clairvoyant reference, the Kalman–Bucy filter optimal for constant σ = σ(0), paper A's ISL filter
at ν, the adaptive Kalman–Bucy filter, the variational-Bayes filter and the robust (Huber) filter — the three learning
σ over [σ min, σ max] from its geometric middle — and the model-aware ISL filter at the same ν.
"""
from __future__ import annotations

import io
import math
from dataclasses import dataclass
from functools import partial

import numpy as np
import param

from isl_core import (
    Model,
    Rolling,
    Scenario,
    ScenarioAverage,
    WhoWinsMap,
    adaptive_kbf,
    average_scenario,
    robust_kbf,
    scenario_grid,
    variational_kbf,
    who_wins_map,
)
from isl_core.filters.isl import model_aware_isl
from isl_core.paper import a31_nu_over_beta
from isl_core.scenario import NOISE_LAWS
from isl_core.scenario.map import MAPS
from isl_core.scenario.table import PRESETS as TABLE_PRESETS

from .text import R_MIN, num, per_r_min

__all__ = ["CHOICE_LABELS", "INPUTS", "MAP_INPUTS", "PICTURE_INPUTS", "PRESETS", "Picture", "ScenarioInputs", "ScenarioRequest",
           "picture_csv", "scenario_picture"]

PICTURE_INPUTS = ("sc_change", "sc_change_at", "sc_sigma_after", "sc_noise", "sc_dof", "sc_outlier_rate",
                  "sc_outlier_scale", "sc_sensor", "sc_horizon", "sc_window", "sc_runs")
MAP_INPUTS = ("sc_map", "sc_map_seeds")
INPUTS = PICTURE_INPUTS + MAP_INPUTS
#: how the page names the choices of the scenario's selectors (their values are the link's and the core's)
CHOICE_LABELS = {
    "sc_change": {"none": "none", "step": "one step", "drift": "a drift"},
    "sc_noise": {"gaussian": "Gaussian", "student": "Student-t", "outliers": "Gaussian with outliers"},
    "sc_map": {"sigma_step": "a σ step", "tails": "heavy tails", "sensor": "the sensor interval"},
}
#: runs × steps of one picture: ≈ 2.3 µs a step for the seven filters on this 2-core machine, so ≈ 9 s at most
PICTURE_MAX_STEPS = 4_000_000
BURN = 2.0  #: the worst case leaves out the first 2/r_min (each filter's start from its own guess)
SHORT_PER_WINDOW = 10  #: short windows per rolling window (the rolling window moves by a tenth of its width)


def _preset_inputs(sigma0: float, scenario: Scenario) -> dict:
    knots = scenario.sigma_knots
    change = {"sc_change": "none"} if not knots else {
        "sc_change": "step" if scenario.sigma_shape == "steps" else "drift", "sc_change_at": knots[0][0],
        "sc_sigma_after": knots[0][1]}
    beta = 3.0 * math.sqrt(2.0)  # the table's model: α = 1, w = 3, m = 3 (A.25)
    return {"alpha": 1.0, "beta_from_w": True, "w": 3.0, "m": 3, "nu": beta * a31_nu_over_beta(1.0, 3, 3.0),
            "sigma": sigma0, **change, "sc_noise": scenario.noise, "sc_dof": scenario.dof,
            "sc_outlier_rate": scenario.outlier_rate, "sc_outlier_scale": scenario.outlier_scale,
            "sc_sensor": scenario.sensor_interval}


#: the columns of the scenario table (isl_core.scenario.table.PRESETS) as dashboard inputs: α = 1, w = 3, m = 3 and
#: ν of table (A.31), as the table runs them
PRESETS = {label.replace("r_min", R_MIN): _preset_inputs(sigma0, sc) for label, sigma0, sc in TABLE_PRESETS.values()}


@dataclass(frozen=True)
class ScenarioRequest:
    """What one picture needs: the model, ν, the σ range of the learning filters, the scenario and its settings."""

    alpha: float
    beta: float
    sigma: float
    m: int
    nu: float
    seed: int
    sigma_range: tuple[float, float]
    scenario: Scenario
    horizon: float
    window: float
    runs: int

    @property
    def model(self) -> Model:
        return Model(self.alpha, self.beta, self.sigma, self.m)


@dataclass(frozen=True)
class Picture:
    """A computed picture: the runs, the rolling ratios, the worst cases (None with one run) and the request."""

    request: ScenarioRequest
    average: ScenarioAverage
    rolling: Rolling
    worst: tuple[np.ndarray, np.ndarray, np.ndarray] | None


def filters(req: ScenarioRequest) -> list:
    """The extra filters of a picture (module docstring); the run adds the clairvoyant, σ(0)-optimal and ISL ones."""
    model = req.model
    guess = math.sqrt(req.sigma_range[0] * req.sigma_range[1])
    return [adaptive_kbf(model, sigma_range=req.sigma_range, sigma_init=guess),
            variational_kbf(model, sigma_init=guess),
            robust_kbf(model, sigma_range=req.sigma_range, sigma_init=guess),
            model_aware_isl(model, req.nu)]


def scenario_picture(req: ScenarioRequest, progress=None) -> Picture:
    """Simulate ``req`` (module docstring); a ``ValueError`` in words if it is too long for the dashboard."""
    extra = filters(req)
    _, n, _ = scenario_grid(req.model, req.nu, req.scenario, extra, req.horizon)
    if n * req.runs > PICTURE_MAX_STEPS:
        most = max(1, PICTURE_MAX_STEPS // n)
        raise ValueError(f"{req.runs} runs of {n:,} steps are {n * req.runs:,} steps, over the dashboard's "
                         f"{PICTURE_MAX_STEPS:,} for a scenario: lower the runs averaged (sc_runs) to {most} or the "
                         "scenario horizon (sc_horizon)")
    windows = max(1, min(n, round(SHORT_PER_WINDOW * req.horizon / req.window)))
    avg = average_scenario(req.model, req.nu, req.scenario, seeds=range(req.seed, req.seed + req.runs),
                           horizon=req.horizon, windows=windows, extra=extra, progress=progress)
    rolling = avg.rolling(req.window)
    worst = None
    if req.runs > 1 and req.horizon > BURN + req.window:
        worst = avg.worst(width=req.window, burn=BURN)
    return Picture(req, avg, rolling, worst)


def picture_csv(pic: Picture) -> str:
    """The picture's rolling ratios, intervals, σ(t) and σ̂(t) as CSV, its settings in ``#`` lines above."""
    req, roll, run = pic.request, pic.rolling, pic.average.run
    out = io.StringIO()
    out.write(f"# isl scenario picture: alpha={req.alpha:g} beta={req.beta:g} sigma(0)={req.sigma:g} m={req.m} "
              f"nu={req.nu:g} seeds={req.seed}..{req.seed + req.runs - 1} horizon={req.horizon:g}/r_min "
              f"window={roll.width:g}/r_min sigma_range={req.sigma_range[0]:g}..{req.sigma_range[1]:g}\n")
    out.write(f"# scenario: {req.scenario!r}\n")
    out.write("# ratio: RMSE of the filter over the clairvoyant filter's exact sd, worst coordinate, mean square over "
              "the seeds (simulated); low/high: 95 % interval over the seeds\n")
    names = run.names
    cols = ["t_over_r_min", "sigma"] + [f"sigma_hat_{n}" for n in pic.average.learning]
    for n in names:
        cols += [f"ratio_{n}", f"low_{n}", f"high_{n}", f"coordinate_{n}"]
    out.write(",".join(cols) + "\n")
    for j, t in enumerate(roll.t):
        row = [f"{t:.6g}", f"{roll.sigma[j]:.6g}", *(f"{v:.6g}" for v in roll.sigma_hat[j])]
        for f in range(len(names)):
            row += [f"{roll.ratio[j, f]:.6g}", f"{roll.low[j, f]:.6g}", f"{roll.high[j, f]:.6g}",
                    str(int(roll.coordinate[j, f]) + 1)]
        out.write(",".join(row) + "\n")
    return out.getvalue()


class ScenarioInputs(param.Parameterized):
    """Inputs and outputs of the Scenario group (module docstring). The host provides ``_jobs``, ``describe``,
    ``_say``, the model's inputs and ``sigma_range``; it calls :meth:`_init_scenario` once its jobs exist."""

    sc_change = param.Selector(objects=["none", "step", "drift"], default="step", label="σ change", doc=(
        "How σ changes: not at all, one step, or a log-linear drift from σ(0) to the value after it."))
    sc_change_at = param.Number(10.0, bounds=(0.1, 1000.0), label=f"change at (× 1/{R_MIN})", doc=(
        f"When σ has changed: the step's time, or the end of the drift, in units of 1/{R_MIN} at σ(0)."))
    sc_sigma_after = param.Number(2.0, bounds=(0.1, 1000.0), label="σ after", doc=(
        "σ after the change (σ before it is the σ input)."))
    sc_noise = param.Selector(objects=list(NOISE_LAWS), default="gaussian", label="noise law",
                              doc="The observation noise's law per step, scaled so that σ stays its intensity.")
    sc_dof = param.Number(3.0, bounds=(2.1, 1000.0), label="Student-t degrees of freedom", doc=(
        "d of the Student-t noise (d > 2: finite variance); small d, heavy tails."))
    sc_outlier_rate = param.Number(0.01, bounds=(0.0, 0.5), label="outlier fraction", doc=(
        "Fraction ε of the steps whose noise is k times larger."))
    sc_outlier_scale = param.Number(30.0, bounds=(1.0, 1000.0), label="outlier size k", doc=(
        "How much larger an outlier's noise is (k)."))
    sc_sensor = param.Number(0.0, bounds=(0.0, 5.0), label=f"sensor interval (× 1/{R_MIN})", doc=(
        "The filters read the integrated observation every Δ (0: at every simulation step)."))
    sc_horizon = param.Number(30.0, bounds=(5.0, 500.0), label=f"scenario horizon (× 1/{R_MIN})", doc=(
        f"Length of each scenario run in units of 1/{R_MIN} at σ(0)."))
    sc_window = param.Number(1.0, bounds=(0.1, 50.0), label=f"rolling window (× 1/{R_MIN})", doc=(
        "Width of the window over which each point's RMSE ratio is taken."))
    sc_runs = param.Integer(32, bounds=(1, 256), label="runs averaged", doc=(
        "Independent runs (seeds from the seed input on) whose mean squared errors are averaged."))
    sc_map = param.Selector(objects=list(MAPS), default="sigma_step", label="map over", doc=(
        "The who-wins map's axis: the σ step's ratio (× time since the step), the tails' degrees of freedom, or the "
        "sensor interval."))
    sc_map_seeds = param.Integer(16, bounds=(2, 128), label="map seeds", doc="Independent runs per cell of the map.")

    scenario = param.ClassSelector(class_=Picture, default=None, allow_None=True, precedence=-1)
    sc_preset_note = param.String("", precedence=-1, doc="What the last scenario preset set beyond the scenario.")
    scenario_busy = param.Boolean(False, precedence=-1)
    scenario_note = param.String("", precedence=-1, doc="Status line of the scenario picture.")
    sc_map_result = param.ClassSelector(class_=WhoWinsMap, default=None, allow_None=True, precedence=-1)
    sc_map_busy = param.Boolean(False, precedence=-1)
    sc_map_progress = param.Number(0.0, bounds=(0.0, 1.0), precedence=-1)
    sc_map_note = param.String("", precedence=-1, doc="Status line of the who-wins map.")

    def _init_scenario(self, long_task) -> None:
        self._scenario_wanted = False
        self._map_task = long_task(self, busy="sc_map_busy", progress="sc_map_progress", note="sc_map_note")
        self.param.watch(self._on_scenario_inputs, ["alpha", "beta_from_w", "w", "beta", "sigma", "m", "nu", "seed",
                                                    "sigma_min", "sigma_max", *PICTURE_INPUTS])

    def scenario_request(self) -> ScenarioRequest:
        """The picture's request from the current inputs (``ValueError`` in words for an impossible scenario)."""
        knots = () if self.sc_change == "none" else ((self.sc_change_at, self.sc_sigma_after),)
        scenario = Scenario(sigma_knots=knots, sigma_shape="drift" if self.sc_change == "drift" else "steps",
                            noise=self.sc_noise, dof=self.sc_dof, outlier_rate=self.sc_outlier_rate,
                            outlier_scale=self.sc_outlier_scale, sensor_interval=self.sc_sensor)
        if self.sc_window > self.sc_horizon:
            raise ValueError(f"the rolling window (sc_window = {self.sc_window:g}) must not be longer than the "
                             f"scenario horizon (sc_horizon = {self.sc_horizon:g})")
        return ScenarioRequest(self.alpha, self.beta_effective, self.sigma, self.m, self.nu, self.seed,
                               self.sigma_range, scenario, self.sc_horizon, self.sc_window, self.sc_runs)

    def want_scenario(self) -> None:
        """The Scenario tab is on screen: compute its picture, now and whenever an input changes."""
        if not self._scenario_wanted:
            self._scenario_wanted = True
            self.compute_scenario()

    def _on_scenario_inputs(self, *events) -> None:
        if self._scenario_wanted:
            self.compute_scenario()

    def compute_scenario(self) -> None:
        """Simulate the picture for the current inputs (a job on the pool of large runs; a newer one supersedes it)."""
        try:
            req = self.scenario_request()
        except ValueError as exc:
            self.scenario_note = f"Not simulated: {exc}."
            return
        self.param.update(scenario_busy=True, scenario_note=f"Simulating {req.runs} runs of the scenario …")
        self._jobs.submit("scenario", partial(scenario_picture, req), self._apply_scenario, pool="large",
                          cancellable=True)

    def _apply_scenario(self, outcome, superseded: bool) -> None:
        if superseded:
            return
        if outcome.error is not None:
            self.param.update(scenario_busy=False, scenario_note=f"Not simulated: {self.describe(outcome.error)}.")
            return
        pic: Picture = outcome.value
        req = pic.request
        self.param.update(scenario=pic, scenario_busy=False, scenario_note=(
            f"Simulated in {outcome.seconds:.2g} s: {req.runs} runs (seeds {req.seed}–{req.seed + req.runs - 1}) of "
            f"{per_r_min(req.horizon)}, {pic.average.run.N:,} steps of h = {pic.average.run.h:.3g} each; each point is "
            f"the RMSE over a window of {per_r_min(pic.rolling.width, 3)} centred on it, over the clairvoyant filter's "
            "exact standard deviation, at the worst coordinate"
            + (", with a 95 % interval over the runs." if req.runs > 1 else " (one run: no interval).")))

    def scenario_csv(self) -> io.StringIO:
        """The picture on screen as CSV (:func:`picture_csv`), for the download button."""
        if self.scenario is None:
            raise ValueError("there is no scenario picture yet")
        return io.StringIO(picture_csv(self.scenario))

    def compute_map(self) -> None:
        """The who-wins map as the session's long job (progress in ``sc_map_progress``; cancellable)."""
        if blocked := self.refused_among(MAP_INPUTS):
            self.sc_map_note = blocked
            return
        if self.alpha <= 0.0:
            self.sc_map_note = "Not started: the map is for paper A's model, which needs α > 0."
            return
        # the page's model: paper A's with w = β/√(2α) when β is an input (β = w√(2α), A.25)
        w = self.w if self.beta_from_w else self.beta_effective / math.sqrt(2.0 * self.alpha)
        fn = partial(who_wins_map, self.sc_map, self.alpha, m=self.m, w=w, seeds=self.sc_map_seeds)
        cells = len(MAPS[self.sc_map])
        self._map_task.start(fn, self._apply_map, f"Simulating {cells} cells × {self.sc_map_seeds} runs …")

    def apply_scenario_preset(self, label: str) -> None:
        """Set the inputs of scenario preset ``label`` (:data:`PRESETS`) in one batch."""
        if label not in PRESETS:
            self._say(f"Unknown scenario preset {label!r}; choose one of {', '.join(PRESETS)}.", "danger")
            return
        values = PRESETS[label]
        self.param.update(**values)
        text = (f"Scenario preset “{label}”: the model's inputs in the sidebar were set too — α = "
                f"{num(values['alpha'])}, w = {num(values['w'])}, m = {values['m']}, σ(0) = {num(values['sigma'])}, "
                f"ν = {num(values['nu'], 3)} (paper A's table A.31) — as the scenario table runs them.")
        self._say(text, "info")
        self.sc_preset_note = text

    def cancel_map(self) -> None:
        self._map_task.cancel()

    def _apply_map(self, outcome) -> None:
        res: WhoWinsMap = outcome.value
        self.param.update(sc_map_result=res, sc_map_note=(
            f"Simulated in {outcome.seconds:.2g} s: the page's model with σ(0) = 20 (α = {res.alpha:g}, "
            f"β = {res.model.beta:.4g}, m = {res.model.m}: paper A's with w = β/√(2α) = "
            f"{res.model.beta / math.sqrt(2.0 * res.alpha):.4g}); {res.seeds} runs per cell, windows of "
            f"{per_r_min(res.window)}; the filters' ν "
            "from table (A.31) and the minimax recommendation, as in `isl scenario --map`."))

