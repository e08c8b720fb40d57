"""The dashboard's state: every user input (bounds, label, doc), the latest run, and what went wrong.

:class:`AppState` is the only place that talks to :mod:`isl_core`. Its inputs are the model (α, β or w,
σ, m; SPEC §1), the ISL filter's ν (A.17), the noise seed and the horizon ``T = horizon / r_min`` (A.24);
the Fig. 2 view adds the σ values and the horizon of its sweep. Every assignment to an input — from a
widget, from the URL, from a script — is checked here, once: a bad value (nan, inf, out of range, wrong
type, None, a string, a boolean) is refused with a message naming the input and its range, and the last
good run stays on screen. Errors of the core (too many steps, a diverged filter) become messages too.

Runs (:mod:`app.pipeline`) and sweeps are computed by :class:`app.jobs.Jobs`: off the event loop when the app
gives it thread pools, inline otherwise (tests, scripts). Outputs (``run``, ``traces``, ``prediction``, ``curves``,
``points``, ``message`` …) are written only by the state itself.
"""
from __future__ import annotations

import io
import math
from functools import partial

import param

from isl_core.runview import RunView

from . import extras, inputs, scenario, sweeps
from .export import run_csv, run_png
from .jobs import Jobs, LongTask, Outcome
from .pipeline import HORIZON_BOUNDS, LIVE_MAX_STEPS, Request, Result, Traces, compute, describe
from .presets import PRESETS
from .text import R_MIN

__all__ = ["ALL_INPUTS", "DISPLAY_INPUTS", "INPUTS", "KINDS", "SWEEP_INPUTS", "TABS", "VIEWS", "AppState",
           "input_label"]


INPUTS = ("alpha", "beta_from_w", "w", "beta", "sigma", "nu", "m", "seed", "horizon")
SWEEP_INPUTS = ("sweep_sigmas", "sweep_horizon")
#: how the page shows the run, kept in the link like the inputs (a shared link, presenter mode's reload); no new run
DISPLAY_INPUTS = ("view", "tab", "present")
ALL_INPUTS = (*INPUTS, *SWEEP_INPUTS, *extras.INPUTS, *scenario.INPUTS, *DISPLAY_INPUTS)
VIEWS = ("signal", "errors")  #: the trajectories' two views: the signal and its estimates, or each filter's error
TABS = ("trajectories", "sweep", "worstcase", "compare", "scenarios")  #: the page's tabs, in order
SWEEP_SIGMA_BOUNDS = (0.1, 1000.0)


def input_label(name: str, link: bool = False) -> str:
    """How messages name input ``name``: its label, and with ``link`` how a link spells it (``σ (sigma=… in the
    link)``)."""
    label = AppState.param[name].label
    if not link:
        return label
    return f"{name}=… in the link" if label == name else f"{label} ({name}=… in the link)"


class AppState(extras.Baselines, scenario.ScenarioInputs):
    """Inputs of the dashboard, validated on assignment, and the latest results (see the module docstring).

    The extra filters' and the worst-case table's inputs come from :class:`app.extras.Baselines`, the Scenario
    group's from :class:`app.scenario.ScenarioInputs`.
    """

    alpha = param.Number(0.5, bounds=(0.0, 100.0), label="α", doc=(
        "Damping of the top derivative Xₘ, dXₘ = −α Xₘ dt + β dv (A.5); α = 0 is paper B's white-noise model."))
    beta_from_w = param.Boolean(True, label="β from w", doc=(
        "Paper A's parametrization (A.25): β = w·√(2α), w = stationary std of Xₘ. Off: β is set directly."))
    w = param.Number(3.0, bounds=(0.01, 100.0), label="w", doc=(
        "Stationary standard deviation of Xₘ (A.25); used when 'β from w' is on. Paper A: w = 3."))
    beta = param.Number(3.0, bounds=(0.01, 1000.0), label="β", doc=(
        "Intensity of the noise driving Xₘ (A.5); used when 'β from w' is off."))
    sigma = param.Number(20.0, bounds=(0.1, 1000.0), label="σ", doc=(
        "Observation noise intensity, dY = X₁ dt + σ dε (A.6). Known to the Kalman–Bucy filter only."))
    nu = param.Number(3.0, bounds=(0.001, 10000.0), label="ν", doc=(
        "The ISL filter's only tuning knob (A.17); paper A studies ν/β = 2^ℓ, ℓ = −8..2."))
    m = param.Integer(3, bounds=(1, 6), label="m", doc="State dimension: X₁ and its m − 1 derivatives (A.1).")
    seed = param.Integer(1, bounds=(0, 2**31 - 1), label="seed", doc="Seed of the noise: same seed, same run.")
    horizon = param.Number(10.0, bounds=HORIZON_BOUNDS, label=f"horizon (× 1/{R_MIN})", doc=(
        f"Simulated time T in units of the optimal filter's settling time 1/{R_MIN} (A.24); paper A, Fig. 3: 10."))
    view = param.Selector(objects=list(VIEWS), default="signal", label="trajectory view",
                          doc="The trajectory plots draw the signal and its estimates, or each filter's error.")
    tab = param.Selector(objects=list(TABS), default="trajectories", label="open tab", doc="The tab on screen.")
    present = param.Boolean(False, label="presenter mode", doc="Larger text for a projector, the controls folded away.")
    sweep_sigmas = param.List([2.0, 20.0, 200.0], item_type=float, bounds=(1, 5), label="σ values", doc=(
        "σ of the sweep's curves (1 to 5 values in [0.1, 1000]); paper A, Fig. 2: 2, 20, 200."))
    sweep_horizon = param.Number(200.0, bounds=(20.0, 2000.0), label=f"sweep horizon (× 1/{R_MIN})", doc=(
        f"Length of each simulated sweep run in units of 1/{R_MIN}; ±2 % needs about 1000."))

    run = param.ClassSelector(class_=RunView, default=None, allow_None=True, precedence=-1,
                              doc="The latest good run (decimated for display).")
    traces = param.ClassSelector(class_=Traces, default=None, allow_None=True, precedence=-1)
    prediction = param.Array(default=None, allow_None=True, precedence=-1, doc="Predicted š_i/s_i of `run`.")
    compute_seconds = param.Number(0.0, precedence=-1, doc="Wall time of the latest run's computation.")
    busy = param.Boolean(False, precedence=-1, doc="A large run (not followed live) is being computed.")
    message = param.String("", precedence=-1, doc="What the user should know: a refused input, an error.")
    message_kind = param.Selector(objects=["info", "warning", "danger"], default="info", precedence=-1)
    refusals = param.Dict(default={}, precedence=-1, doc="Input name → why its last value was refused (shown beside it).")
    message_inline = param.Boolean(False, precedence=-1, doc="The message is one input's refusal, shown beside it.")
    curves = param.ClassSelector(class_=sweeps.SweepCurves, default=None, allow_None=True, precedence=-1)
    curves_note = param.String("", precedence=-1, doc="Why there are no theory curves, if there are none.")
    points = param.ClassSelector(class_=sweeps.SweepPoints, default=None, allow_None=True, precedence=-1)
    sweep_busy = param.Boolean(False, precedence=-1)
    sweep_progress = param.Number(0.0, bounds=(0.0, 1.0), precedence=-1)
    sweep_note = param.String("", precedence=-1, doc="Status line of the simulated sweep / recommendation.")

    def __init__(self, *, jobs: Jobs | None = None, **params) -> None:
        super().__init__(**params)
        #: the last α > 0 this page had (the default if it opened at α = 0): where unticking "α = 0" goes back to
        self.alpha_before_zero = self.alpha if self.alpha > 0.0 else self.param.alpha.default
        self._jobs = jobs or Jobs()
        self._started = False
        self._quiet = False  # set while the state itself corrects an input (no new run)
        self.shown_request: Request | None = None  # the inputs of the run on screen
        self._curves_wanted = False  # the ν-sweep's theory curves: computed once its tab is open
        self._serial = 0
        self._sweep_task = LongTask(self, busy="sweep_busy", progress="sweep_progress", note="sweep_note")
        self._worst_task = LongTask(self, busy="worst_busy", progress="worst_progress", note="worst_note")
        self._note_context: tuple | None = None  # the sweep context (α, β, m, σs) that ``sweep_note`` reports on
        self._init_scenario(LongTask)
        self.param.watch(self._on_inputs, list(INPUTS))
        self.param.watch(self._on_extra_inputs, list(extras.RUN_INPUTS))
        self.param.watch(self._on_context, ["alpha", "beta_from_w", "w", "beta", "m", "sweep_sigmas",
                                            *extras.RUN_INPUTS])

    # ---- validation at the boundary -------------------------------------------------------------------
    def __setattr__(self, name: str, value) -> None:
        if name in ALL_INPUTS:
            try:
                value = self.clean(name, value)
            except ValueError as exc:
                self._refuse(name, exc)
                return
            if name in self.refusals:  # the refused input has a good value again
                left = {k: v for k, v in self.refusals.items() if k != name}
                if left:
                    self.refusals = left
                else:
                    self._clear()
            if name == "alpha" and value > 0.0:
                self.alpha_before_zero = value
        super().__setattr__(name, value)

    def label_of(self, name: str, link: bool = False) -> str:
        """How messages name an input: its label, and with ``link`` also its name in links (``σ (sigma=…)``)."""
        return input_label(name, link)

    def clean(self, name: str, value, pending: dict | None = None, link: bool = False):
        """``value`` checked for input ``name`` (:mod:`app.inputs`): the clean value or a ``ValueError`` in words.

        ``pending``: other inputs about to be set with it (the σ range is checked against its new other end).
        """
        value = inputs.clean(self.label_of(name, link), value, KINDS[name])
        if name in ("sigma_min", "sigma_max"):
            ends = {"sigma_min": self.sigma_min, "sigma_max": self.sigma_max, **(pending or {}), name: value}
            extras.check_order(ends["sigma_min"], ends["sigma_max"])
        return value

    def set_inputs(self, values: dict, problems: dict[str, str] | None = None, *, link: bool = False) -> list[str]:
        """Set every good value of ``values`` in one batch (one new run); report every bad one, and those in
        ``problems`` (name → message, e.g. a link's unreadable values), in ONE message. Returns the reports.

        ``link``: the values come from a URL (messages then give each input's name in links too)."""
        bad = dict(problems or {})
        good = {}
        for name, value in values.items():
            try:
                good[name] = self.clean(name, value, {k: v for k, v in values.items() if k != name}, link)
            except ValueError as exc:
                bad[name] = str(exc)
        if good:
            self.param.update(**good)
        if bad:
            kept = "the last good run is kept" if self.run is not None else "nothing was simulated for them"
            what = "a value" if len(bad) == 1 else f"{len(bad)} values"
            self._say(f"Refused {what} (each keeps its previous setting; {kept}): " + "; ".join(bad.values()) + ".",
                      "danger")
            self.refusals = {name: f"Refused: {text}." for name, text in bad.items() if name in ALL_INPUTS}
        return list(bad.values())

    def _refuse(self, name: str, exc: ValueError) -> None:
        """A refusal stays on screen, beside the input, until that input gets a good value (or a preset, or another
        message)."""
        kept = "The last good run is kept." if self.run is not None else "Nothing was simulated for it."
        text = f"Refused: {exc}. {kept}"
        self._say(text, "danger", inline=True)
        self.refusals = {name: text}

    def _say(self, text: str, kind: str = "info", *, inline: bool = False) -> None:
        """Show a message (``inline``: one input's refusal, shown beside it); a run requested before it will not clear
        it (see ``_apply_run``)."""
        self._serial += 1
        self.param.update(message=text, message_kind=kind, message_inline=inline, refusals={})

    def _clear(self) -> None:
        if self.message or self.refusals:
            self.param.update(message="", message_kind="info", message_inline=False, refusals={})

    @property
    def beta_effective(self) -> float:
        """β of the model: ``w·√(2α)`` (A.25) when 'β from w' is on, else the β input."""
        return self.w * math.sqrt(2.0 * self.alpha) if self.beta_from_w else self.beta

    @property
    def live(self) -> bool:
        """Whether the current run is small enough to follow a slider while it is dragged."""
        return self.run is None or self.run.N <= LIVE_MAX_STEPS

    @property
    def computing(self) -> bool:
        """A run is in flight (whatever its size)."""
        return self._jobs.busy("run")

    def submit(self, kind: str, fn, done, *, pool: str = "run") -> None:
        """``fn()`` off the event loop, then ``done(outcome, superseded)`` on it (:meth:`app.jobs.Jobs.submit`)."""
        self._jobs.submit(kind, fn, done, pool=pool)

    def refused_among(self, names) -> str:
        """Why a computation over inputs ``names`` does not start: one of them still shows a refused value."""
        bad = ", ".join(self.param[n].label for n in names if n in self.refusals)
        return f"Not started: correct the refused value of {bad} first (it would use the previous one)." if bad else ""

    def later(self, fn) -> None:
        """Run ``fn()`` on the session's loop with its lock held (from any thread; at once outside a server)."""
        self._jobs.later(fn)

    def request(self) -> Request:
        return Request(self.alpha, self.beta_effective, self.sigma, self.nu, self.m, self.seed, self.horizon,
                       tuple(self.extra_filters), self.sigma_design, self.sigma_range)

    # ---- runs ----------------------------------------------------------------------------------------
    def start(self) -> None:
        """Compute the first run and the sweep's theory curves, as jobs (in a served session: off the event loop).

        With no run on screen yet, a run too long for the dashboard is replaced by its nearest allowed setting (a
        shorter horizon, :func:`app.pipeline.fit`): a page opened from any link shows a run or says why it cannot."""
        self._started = True
        if self.alpha == 0.0 and self.beta_from_w:
            self._switch_to_beta()
        self.busy = True
        self._jobs.submit("run", partial(compute, self.request(), nearest=True), partial(self._apply_run, self._serial),
                          cancellable=True)
        if self._curves_wanted:
            self._refresh_curves()

    def _switch_to_beta(self) -> None:
        beta = self.run.model.beta if self.run is not None else self.beta
        beta = min(max(beta, self.param.beta.bounds[0]), self.param.beta.bounds[1])
        self.param.update(beta_from_w=False, beta=beta)
        self._say(f"α = 0: β = w√(2α) would vanish, so β is now set directly (β = {beta:.4g}).", "info")

    def _on_inputs(self, *events) -> None:
        if not self._started:
            return
        if self.alpha == 0.0 and self.beta_from_w:
            self._switch_to_beta()  # its own assignments come back here with a valid model
            return
        if self._quiet:
            return
        self.busy = not self.live  # a small run is back before a spinner could be seen
        nearest = self.run is None  # nothing on screen to keep: show the nearest allowed setting instead
        self._jobs.submit("run", partial(compute, self.request(), nearest=nearest),
                          partial(self._apply_run, self._serial), pool="run" if self.live else "large",
                          cancellable=True)

    def _on_extra_inputs(self, *events) -> None:
        """σ̄ and the σ range change the run only when an extra filter is drawn (or the selection changed)."""
        if self.extra_filters or any(e.name == "extra_filters" for e in events):
            self._on_inputs(*events)

    def _apply_run(self, serial: int, outcome: Outcome, superseded: bool) -> None:
        if outcome.error is not None:
            if not superseded:
                kept = "The last good run is kept." if self.run is not None else "Nothing is shown until it is changed."
                self._say(f"{describe(outcome.error)}. {kept}", "danger")
            self.busy = superseded
            return
        res: Result = outcome.value
        if res.adjusted and not superseded:
            self._quiet = True  # the input now shows what was simulated; that starts no second run
            try:
                self.horizon = res.request.horizon
            finally:
                self._quiet = False
        self.shown_request = res.request
        self.param.update(run=res.run, traces=res.traces, prediction=res.prediction,
                          extra_prediction=res.extra_prediction or {}, compute_seconds=outcome.seconds, busy=superseded)
        if res.adjusted and not superseded:
            self._say(f"Showing the nearest allowed setting: {res.adjusted}.", "warning")
        elif serial == self._serial and not self.refusals:
            self._clear()

    def apply_preset(self, name: str) -> None:
        """Set the inputs of preset ``name`` (see :mod:`app.presets`) in one batch: one new run."""
        if name not in PRESETS:
            self._say(f"Unknown preset {name!r}; choose one of {', '.join(PRESETS)}.", "danger")
            return
        self._clear()
        self.param.update(**PRESETS[name].values)

    def csv(self) -> io.StringIO:
        """The run on screen as CSV (:func:`app.export.run_csv`), for the download button."""
        return io.StringIO(run_csv(self))

    def png(self) -> io.BytesIO:
        """The run on screen as a PNG figure (:func:`app.export.run_png`), for the download button."""
        if self.run is None:
            raise ValueError("there is no run to draw yet")
        return run_png(self.run)

    # ---- the ν-sweep (Fig. 2) ------------------------------------------------------------------------
    def want_curves(self) -> None:
        """The ν-sweep is on screen: compute its theory curves, now and whenever their context changes (a session
        that never opens that tab never computes them)."""
        if not self._curves_wanted:
            self._curves_wanted = True
            if self._started:
                self._refresh_curves()

    def _on_context(self, *events) -> None:
        if self._started:
            self._drop_stale()
            if self._curves_wanted:
                self._refresh_curves()

    def _sweep_model(self) -> tuple[float, float, int, tuple[float, ...]]:
        return self.alpha, self.beta_effective, self.m, tuple(self.sweep_sigmas)

    def _drop_stale(self) -> None:
        """Simulated points and a status note of another context (α, β, m, sweep σ) go stale."""
        key = self._sweep_model()
        pts = self.points
        if pts is not None and (pts.alpha, pts.beta, pts.m, pts.sigmas) != key:
            self.points = None
        if not self.sweep_busy and self._note_context not in (None, key):  # the note spoke of another context
            self.sweep_note, self._note_context = "", None

    def _refresh_curves(self) -> None:
        """Theory curves for the current α, β, m and sweep σ."""
        key = self._sweep_model()
        self._jobs.submit("theory", partial(sweeps.theory_curves, *key, extras=tuple(self.extra_filters),
                                            sigma_design=self.sigma_design, sigma_range=self.sigma_range),
                          self._apply_curves)

    def _apply_curves(self, outcome: Outcome, superseded: bool) -> None:
        if outcome.error is None:
            self.param.update(curves=outcome.value, curves_note="")
        elif not superseded:
            self.param.update(curves=None, curves_note=f"No theory curves: {describe(outcome.error)}.")

    def describe(self, error: BaseException) -> str:
        """A job's failure in words for the page (tracebacks go to the server log)."""
        return describe(error)

    def cancel_sweep(self) -> None:
        """Stop the sweep or recommendation: dropped if it waits in the queue, else ended (see LongTask.cancel)."""
        self._sweep_task.cancel()

    def simulate_sweep(self) -> None:
        """Simulate the sweep's points for the current context (progress in ``sweep_progress``; cancellable)."""
        if blocked := self.refused_among(SWEEP_INPUTS):
            self.sweep_note = blocked
            return
        alpha, beta, m, sigmas = self._sweep_model()
        fn = partial(sweeps.simulate_points, alpha, beta, m, sigmas, horizon=self.sweep_horizon, seed=self.seed)
        self._sweep_task.start(fn, self._apply_points,
                               f"Simulating {len(sigmas)} × {len(sweeps.SIM_LEVELS)} configurations …")

    def _apply_points(self, outcome: Outcome) -> None:
        pts: sweeps.SweepPoints = outcome.value
        if (pts.alpha, pts.beta, pts.m, pts.sigmas) != self._sweep_model():
            self.sweep_note = "The parameters changed while the sweep ran; run it again."
        else:
            self._note_context = self._sweep_model()
            self.param.update(points=pts, sweep_note=sweeps.points_note(pts, outcome.seconds))

    def recommend(self) -> None:
        """Set ν to the value minimizing the worst-case ratio over the sweep's σ (``recommend_nu``, verified)."""
        if blocked := self.refused_among(SWEEP_INPUTS):
            self.sweep_note = blocked
            return
        alpha, beta, m, sigmas = self._sweep_model()
        fn = partial(sweeps.recommend, alpha, beta, m, sigmas, horizon=self.sweep_horizon, seed=self.seed)
        self._sweep_task.start(fn, self._apply_recommendation,
                               "Searching the theory for the best ν, then checking it by simulation …")

    def _apply_recommendation(self, outcome: Outcome) -> None:
        nu, text = outcome.value
        self.nu = min(max(nu, self.param.nu.bounds[0]), self.param.nu.bounds[1])
        self._note_context = self._sweep_model()
        self.sweep_note = text

    def close(self) -> None:
        """End of the session: stop its long job, drop pending work and the large arrays."""
        self._jobs.close()
        with param.parameterized.discard_events(self):  # the views are going away: no redraw
            self.param.update(run=None, traces=None, prediction=None, points=None, curves=None, worst=None,
                              extra_prediction={}, scenario=None, sc_map_result=None)


#: kind and range of every input (:mod:`app.inputs`), from the declarations above
KINDS = inputs.kinds_of(ALL_INPUTS, AppState.param, {"sweep_sigmas": SWEEP_SIGMA_BOUNDS,
                                                     "wc_alphas": extras.ALPHA_BOUNDS})
