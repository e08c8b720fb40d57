"""The Scenario tab's room: σ that changes, heavy-tailed noise, a coarse sensor — against a clairvoyant filter.

The model inputs (α, β, m, ν, seed) are the session's; σ is σ(0), where the scenario starts. :class:`ScenarioRoom`
holds the scenario's own inputs (keys ``sc_…``: declared, linked in the URL and refused in words like every other
input) and computes three things through the core:

* **the picture** (:func:`app.scenario_picture.scenario_picture`): every filter over ``runs`` seeds (the seed input
  and the ones after it) against the clairvoyant Kalman filter that knows σ(t) — the rolling ratio in time, σ(t)
  and each σ-learning filter's σ̂(t), and the period statistic with each filter's tuning and cost. A job on the
  pool of large runs, recomputed when an input changes while the tab is open;
* **the who-wins map** (:func:`isl_core.who_wins_map` for the page's α, β and m at σ(0) = 20): the session's long job
  (progress, cancel, place in the queue);
* **the tuning** (:func:`isl_core.scenario.tuning.tune` for the page's α, m and w): a long job, then cached, which every
  later picture of that model uses.
"""

from __future__ import annotations

import io
import math
from functools import partial
from typing import ClassVar

import param

from isl_core import BOUNDS, TUNING_SAMPLING, Execution, Scenario, WhoWinsMap, who_wins_map
from isl_core.paper import a31_nu_over_beta
from isl_core.scenario import NOISE_LAWS
from isl_core.scenario.map import MAPS
from isl_core.scenario.presets import DEFAULT_RATE
from isl_core.scenario.table import PRESETS as TABLE_PRESETS
from isl_core.scenario.tuning import Tuning, tune

from ..inputs import Real, Whole
from ..jobs import LongTask
from ..scenario_picture import Picture, ScenarioRequest, picture_csv, scenario_picture, tuning_for
from ..text import R_MIN, num, per_r_min
from .room import Room

__all__ = ["CHOICE_LABELS", "INPUTS", "MAP_INPUTS", "PICTURE_INPUTS", "PRESETS", "ScenarioRoom", "tuning_job"]

PICTURE_INPUTS = (
    "sc_change",
    "sc_change_at",
    "sc_sigma_after",
    "sc_noise",
    "sc_dof",
    "sc_outlier_rate",
    "sc_outlier_scale",
    "sc_sensor",
    "sc_horizon",
    "sc_window",
    "sc_runs",
)
MAP_INPUTS = ("sc_map", "sc_map_seeds")
INPUTS = PICTURE_INPUTS + MAP_INPUTS
#: the model's inputs that change the picture
MODEL_INPUTS = ("alpha", "beta_from_w", "w", "beta", "sigma", "m", "nu", "seed")
#: how the page names the choices of the scenario's selectors (their values are the link's and the core's)
CHOICE_LABELS = {
    "sc_change": {"none": "none", "step": "one step", "drift": "a drift"},
    "sc_noise": {"gaussian": "Gaussian", "student": "Student-t", "outliers": "Gaussian with outliers"},
    "sc_map": {"sigma_step": "a σ step", "tails": "heavy tails", "sensor": "the sensor interval"},
}


def _preset_inputs(sigma0: float, scenario: Scenario) -> dict:
    knots = scenario.sigma_knots
    change = (
        {"sc_change": "none"}
        if not knots
        else {
            "sc_change": "step" if scenario.sigma_shape == "steps" else "drift",
            "sc_change_at": knots[0][0],
            "sc_sigma_after": knots[0][1],
        }
    )
    beta = 3.0 * math.sqrt(2.0)  # the table's model: α = 1, w = 3, m = 3 (A.25)
    nu_over_beta = a31_nu_over_beta(1.0, 3, 3.0)
    assert nu_over_beta is not None  # table (A.31) holds this model
    return {
        "alpha": 1.0,
        "beta_from_w": True,
        "w": 3.0,
        "m": 3,
        "nu": beta * nu_over_beta,
        "sigma": sigma0,
        **change,
        "sc_noise": scenario.noise,
        "sc_dof": scenario.dof,
        "sc_outlier_rate": scenario.outlier_rate,
        "sc_outlier_scale": scenario.outlier_scale,
        "sc_sensor": scenario.sensor_interval,
    }


#: the columns of the scenario table (isl_core.scenario.table.PRESETS) as dashboard inputs: α = 1, w = 3, m = 3 and
#: ν of table (A.31), as the table runs them
PRESETS = {label.replace("r_min", R_MIN): _preset_inputs(sigma0, sc) for label, sigma0, sc in TABLE_PRESETS.values()}


def _rate(interval: float) -> str:
    """A sensor interval (units of 1/r_min) as the page states it: the readings per 1/r_min."""
    return f"{1.0 / interval:.3g} times per 1/{R_MIN} at σ(0)"


def tuning_job(alpha: float, m: int, w: float, *, progress) -> Tuning | None:
    """The page's tuning as a long job (``fn(progress=…)``, run in a child process): :func:`isl_core.tune` with the
    job's progress in its execution."""
    return tune(alpha, m=m, w=w, execution=Execution(progress=progress))


class ScenarioRoom(Room):
    """Inputs, picture, map and tuning of the Scenario tab (the module docstring); keys ``sc_…``."""

    KEYS: ClassVar[dict[str, str]] = {key: key[3:] for key in INPUTS}

    change = param.Selector(
        objects=["none", "step", "drift"],
        default="step",
        label="σ change",
        doc=("How σ changes: not at all, one step, or a log-linear drift from σ(0) to the value after it."),
    )
    change_at = Real(
        10.0,
        bounds=(0.1, 1000.0),
        label=f"change at (× 1/{R_MIN})",
        doc=(f"When σ has changed: the step's time, or the end of the drift, in units of 1/{R_MIN} at σ(0)."),
    )
    sigma_after = Real(
        2.0, bounds=BOUNDS.sigma.range, label="σ after", doc=("σ after the change (σ before it is the σ input).")
    )
    noise = param.Selector(
        objects=list(NOISE_LAWS),
        default="gaussian",
        label="noise law",
        doc="The observation noise's law per step, scaled so that σ stays its intensity.",
    )
    dof = Real(
        3.0,
        bounds=(2.1, 1000.0),
        label="Student-t degrees of freedom",
        doc=("d of the Student-t noise (d > 2: finite variance); small d, heavy tails."),
    )
    outlier_rate = Real(
        0.01,
        bounds=(0.0, 0.5),
        label="outlier fraction",
        doc=("Fraction ε of the steps whose noise is k times larger."),
    )
    outlier_scale = Real(
        30.0, bounds=(1.0, 1000.0), label="outlier size k", doc=("How much larger an outlier's noise is (k).")
    )
    sensor = Real(
        0.0,
        bounds=(0.0, 5.0),
        label=f"sensor interval (× 1/{R_MIN})",
        doc=(
            "The filters read the integrated observation every Δ; below 1/100 (0 included) every 1/100: the "
            "scenario table's reading rate, 100 readings per 1/r_min."
        ),
    )
    horizon = Real(
        30.0,
        bounds=(5.0, 500.0),
        label=f"scenario horizon (× 1/{R_MIN})",
        doc=(f"Length of each scenario run in units of 1/{R_MIN} at σ(0)."),
    )
    window = Real(
        1.0,
        bounds=(0.1, 50.0),
        label=f"rolling window (× 1/{R_MIN})",
        doc=("Width of the window over which each point's RMSE ratio is taken."),
    )
    runs = Whole(
        32,
        bounds=(1, 256),
        label="runs averaged",
        doc=("Independent runs (seeds from the seed input on) whose mean squared errors are averaged."),
    )
    map = param.Selector(
        objects=list(MAPS),
        default="sigma_step",
        label="map over",
        doc=(
            "The who-wins map's axis: the σ step's ratio (× time since the step), the tails' degrees of freedom, "
            "or the sensor interval."
        ),
    )
    map_seeds = Whole(16, bounds=(2, 128), label="map seeds", doc="Independent runs per cell of the map.")

    picture = param.ClassSelector(class_=Picture, default=None, allow_None=True, precedence=-1)
    preset_note = param.String("", precedence=-1, doc="What the last scenario preset set beyond the scenario.")
    busy = param.Boolean(False, precedence=-1)
    note = param.String("", precedence=-1, doc="Status line of the scenario picture.")
    map_result = param.ClassSelector(class_=WhoWinsMap, default=None, allow_None=True, precedence=-1)
    map_busy = param.Boolean(False, precedence=-1)
    map_progress = param.Number(0.0, bounds=(0.0, 1.0), precedence=-1)
    map_note = param.String("", precedence=-1, doc="Status line of the who-wins map.")
    tuning = param.ClassSelector(
        class_=Tuning,
        default=None,
        allow_None=True,
        precedence=-1,
        doc="The tuning of the page's α, m and w, when there is one (the tuning curves).",
    )
    tune_busy = param.Boolean(False, precedence=-1)
    tune_progress = param.Number(0.0, bounds=(0.0, 1.0), precedence=-1)
    tune_note = param.String("", precedence=-1, doc="Status line of the tuning.")

    def __init__(self, host, **params) -> None:
        super().__init__(host, **params)
        self._wanted = False  # the picture: computed once the tab is open
        self._map_task = LongTask(self, busy="map_busy", progress="map_progress", note="map_note")
        self._tune_task = LongTask(self, busy="tune_busy", progress="tune_progress", note="tune_note")
        host.param.watch(self._on_inputs, list(MODEL_INPUTS))
        host.baselines.param.watch(self._on_inputs, ["sigma_min", "sigma_max"])
        self.param.watch(self._on_inputs, [self.KEYS[k] for k in PICTURE_INPUTS])

    def _model_w(self) -> float:
        """w of the page's model: paper A's with w = β/√(2α) when β is an input (β = w√(2α), A.25)."""
        host = self._host
        return host.w if host.beta_from_w else host.beta_effective / math.sqrt(2.0 * host.alpha)

    def request(self) -> ScenarioRequest:
        """The picture's request from the current inputs (``ValueError`` in words for an impossible scenario)."""
        knots = () if self.change == "none" else ((self.change_at, self.sigma_after),)
        scenario = Scenario(
            sigma_knots=knots,
            sigma_shape="drift" if self.change == "drift" else "steps",
            noise=self.noise,
            dof=self.dof,
            outlier_rate=self.outlier_rate,
            outlier_scale=self.outlier_scale,
            sensor_interval=max(float(self.sensor), 1.0 / DEFAULT_RATE),  # the table's reading rate, or a slower sensor
        )
        if self.window > self.horizon:
            raise ValueError(
                f"the rolling window (sc_window = {self.window:g}) must not be longer than the "
                f"scenario horizon (sc_horizon = {self.horizon:g})"
            )
        h = self._host
        return ScenarioRequest(
            h.alpha,
            h.beta_effective,
            h.sigma,
            h.m,
            h.nu,
            h.seed,
            h.baselines.sigma_range,
            scenario,
            self.horizon,
            self.window,
            self.runs,
        )

    def want(self) -> None:
        """The Scenario tab is on screen: compute its picture, now and whenever an input changes."""
        if not self._wanted:
            self._wanted = True
            self.compute()

    def _on_inputs(self, *events) -> None:
        if self._wanted:
            self.compute()

    def compute(self) -> None:
        """Simulate the picture for the current inputs (a job on the pool of large runs; a newer one supersedes it)."""
        try:
            req = self.request()
        except ValueError as exc:
            self.note = f"Not simulated: {exc}."
            return
        self.param.update(busy=True, note=f"Simulating {req.runs} runs of the scenario …")
        self.jobs.submit("scenario", partial(scenario_picture, req), self._apply, pool="large", cancellable=True)

    def _apply(self, outcome, superseded: bool) -> None:
        if superseded:
            return
        if outcome.error is not None:
            self.param.update(busy=False, note=f"Not simulated: {self.describe(outcome.error)}.")
            return
        pic: Picture = outcome.value
        req = pic.request
        self.param.update(
            picture=pic,
            tuning=pic.tuned,
            busy=False,
            note=(
                f"Simulated in {outcome.seconds:.2g} s: {req.runs} runs "
                f"(seeds {pic.average.seeds[0]}–{pic.average.seeds[-1]}) of {per_r_min(req.horizon)}, "
                f"{pic.average.run.N:,} steps of h = {pic.average.run.h:.3g} each; every filter reads the sensor "
                f"{_rate(req.scenario.sensor_interval)} (each reading the integral of dY over its interval), "
                f"{pic.average.run.q} steps a reading. Tuning: {pic.origin}."
            ),
        )

    def csv(self) -> io.StringIO:
        """The picture on screen as CSV (:func:`app.scenario_picture.picture_csv`), for the download button."""
        if self.picture is None:
            raise ValueError("there is no scenario picture yet")
        return io.StringIO(picture_csv(self.picture))

    def compute_map(self) -> None:
        """The who-wins map as the session's long job (progress in ``map_progress``; cancellable)."""
        if blocked := self.refused_among(MAP_INPUTS):
            self.map_note = blocked
            return
        if self._host.alpha <= 0.0:
            self.map_note = "Not started: the map is for paper A's model, which needs α > 0."
            return
        host = self._host
        fn = partial(who_wins_map, self.map, host.alpha, m=host.m, w=self._model_w(), n_seeds=self.map_seeds)
        cells = len(MAPS[self.map])
        self._map_task.start(fn, self._apply_map, f"Simulating {cells} cells × {self.map_seeds} runs …")

    def cancel_map(self) -> None:
        """Stop the map: dropped if it waits in the queue, else ended."""
        self._map_task.cancel()

    def apply_preset(self, label: str) -> None:
        """Set the inputs of scenario preset ``label`` (:data:`PRESETS`), the model's among them, in one batch."""
        host = self._host
        if label not in PRESETS:
            host.say(f"Unknown scenario preset {label!r}; choose one of {', '.join(PRESETS)}.", "danger")
            return
        values = PRESETS[label]
        host.set_inputs(values)
        text = (
            f"Scenario preset “{label}”: the model's inputs in the sidebar were set too — α = "
            f"{num(values['alpha'])}, w = {num(values['w'])}, m = {values['m']}, σ(0) = {num(values['sigma'])}, "
            f"ν = {num(values['nu'], 3)} (paper A's table A.31) — as the scenario table runs them."
        )
        host.say(text, "info")
        self.preset_note = text

    def find_tuning(self) -> None:
        """The cached tuning of the page's model into ``tuning`` (None if there is none)."""
        try:
            found = tuning_for(self.request())
            self.tuning = found if isinstance(found, Tuning) else None  # a shipped one has no curves to draw
        except ValueError:
            self.tuning = None

    def compute_tuning(self) -> None:
        """Tune every family for the page's α, m and w (:func:`isl_core.scenario.tuning.tune`: minutes on two cores,
        then cached) as the session's long job; the picture and the curves follow it."""
        if self._host.alpha <= 0.0:
            self.tune_note = "Not started: the tuning is for paper A's model, which needs α > 0."
            return
        fn = partial(tuning_job, self._host.alpha, self._host.m, self._model_w())
        busy = (
            f"Tuning every filter: 6 presets × {TUNING_SAMPLING.n_seeds} seeds, 268 variants, {DEFAULT_RATE:g} "
            f"readings per 1/{R_MIN} …"
        )
        self._tune_task.start(fn, self._apply_tuning, busy)

    def cancel_tuning(self) -> None:
        """Stop the tuning: dropped if it waits in the queue, else ended."""
        self._tune_task.cancel()

    def _apply_tuning(self, outcome) -> None:
        self.param.update(tuning=outcome.value, tune_note=f"Tuned in {outcome.seconds:.0f} s: {outcome.value.origin}.")
        if self._wanted:
            self.compute()

    def _apply_map(self, outcome) -> None:
        res: WhoWinsMap = outcome.value
        self.param.update(
            map_result=res,
            map_note=(
                f"Simulated in {outcome.seconds:.2g} s: the page's model with σ(0) = 20 (α = {res.alpha:g}, "
                f"β = {res.model.beta:.4g}, m = {res.model.m}: paper A's with w = β/√(2α) = "
                f"{res.model.beta / math.sqrt(2.0 * res.alpha):.4g}); {len(res.seeds)} runs per cell (seeds "
                f"{res.seeds[0]}–{res.seeds[-1]}), windows of "
                f"{per_r_min(res.window)}; filters tuned as in the scenario table: {res.origin}."
            ),
        )

    def release(self) -> None:
        """The session ends: drop the picture and the map without a redraw."""
        with param.parameterized.discard_events(self):
            self.param.update(picture=None, map_result=None)
