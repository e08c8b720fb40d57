"""A session's state: the model's inputs, the run on screen, what went wrong — and the rooms of the other concerns.

:class:`AppState` is the page's one state object. It holds the model (α, β or w, σ, m; :ref:`model-equations`), the
ISL filter's ν (A.17), the noise seed and the horizon ``T = horizon / r_min`` (A.24), how the page shows them (view,
tab, presenter mode), the latest run and the page's message; the other concerns live in rooms it composes
(:class:`app.state.Room`): :attr:`~AppState.baselines` (the extra filters), :attr:`~AppState.sweep` (the ν-sweep),
:attr:`~AppState.worstcase` and :attr:`~AppState.scenarios`.

Every input has a *key* — its name in links, messages and refusals (``sigma``, ``sc_runs``) — and one check, its
declaration: param refuses a bad value when it is assigned (``state.sigma = "x"`` raises its ``ValueError``). Values
from outside — a widget, a link, a script — come in through :meth:`AppState.set` and :meth:`AppState.set_inputs`,
which put a refusal in words beside its input, naming it and its range, while the last good run stays on screen; the
σ range's two ends, judged together, are the one check made there. A run the core refuses
(too many steps, a diverged filter) takes its inputs back to the run on screen (:mod:`app.state.refused_run`). Runs
(:mod:`app.pipeline`) are jobs (:class:`app.jobs.Jobs`): off the event loop when served, inline in tests and scripts.
"""

from __future__ import annotations

import contextlib
import io
import math
from functools import partial

import param

from isl_core.runview import RunView

from .. import inputs
from ..export import run_csv, run_png
from ..extras import check_order
from ..jobs import Jobs, Outcome
from ..pipeline import LIVE_MAX_STEPS, Request, Result, Traces, compute, describe
from ..presets import PAPER_PRESETS
from .baselines import BaselinesRoom
from .data import DataRoom
from .refused_run import RUN_KEYS, refuse_run, run_refusal_shown
from .room import Room
from .scenarios import ScenarioRoom
from .session_inputs import DISPLAY_INPUTS, INPUTS, TABS, VIEWS, SessionInputs
from .sweep import SweepRoom
from .worstcase import WorstCaseRoom

__all__ = [
    "ALL_INPUTS",
    "DISPLAY_INPUTS",
    "INPUTS",
    "OWNERS",
    "ROOMS",
    "SIGMA_ENDS",
    "TABS",
    "VIEWS",
    "AppState",
    "declaration",
    "input_label",
]

#: the session's rooms: attribute → class (built in this order: a room may watch the ones before it)
ROOMS: dict[str, type[Room]] = {
    "baselines": BaselinesRoom,
    "sweep": SweepRoom,
    "worstcase": WorstCaseRoom,
    "scenarios": ScenarioRoom,
    "data": DataRoom,
}
#: every input's key → (the room's attribute, None for the session's own, and the parameter's name)
OWNERS: dict[str, tuple[str | None, str]] = {
    **{k: (None, k) for k in (*INPUTS, *DISPLAY_INPUTS)},
    **{key: (attr, name) for attr, cls in ROOMS.items() for key, name in cls.KEYS.items()},
}
ALL_INPUTS = tuple(OWNERS)  #: every input's key: what a link carries
SIGMA_ENDS = ("sigma_min", "sigma_max")  #: the σ range's ends: each must stay on its side of the other


def declaration(key: str) -> param.Parameter:
    """The declaration of input ``key`` (a ``param.Parameter``: its label, doc, bounds and default), on its class."""
    attr, name = OWNERS[key]
    return (AppState if attr is None else ROOMS[attr]).param[name]


def input_label(name: str, link: bool = False) -> str:
    """How messages name input ``name`` (a key): its label, and with ``link`` how a link spells it (``σ (sigma=… in
    the link)``)."""
    label = declaration(name).label
    if not link:
        return label
    return f"{name}=… in the link" if label == name else f"{label} ({name}=… in the link)"


class AppState(SessionInputs):
    """The session's inputs (each refuses a bad value on assignment), its run and message, and its rooms (the module
    docstring)."""

    run = param.ClassSelector(class_=RunView, default=None, allow_None=True, precedence=-1, doc="The run on screen.")
    traces = param.ClassSelector(class_=Traces, default=None, allow_None=True, precedence=-1)
    prediction = param.Array(default=None, allow_None=True, precedence=-1, doc="Predicted š_i/s_i of `run`.")
    compute_seconds = param.Number(0.0, precedence=-1, doc="Wall time of the latest run's computation.")
    busy = param.Boolean(False, precedence=-1, doc="A large run (not followed live) is being computed.")
    message = param.String("", precedence=-1, doc="What the user should know: a refused input, an error.")
    message_kind = param.Selector(objects=["info", "warning", "danger"], default="info", precedence=-1)
    refusals = param.Dict(default={}, precedence=-1, doc="Input key → why its value was refused (shown beside it).")
    message_inline = param.Boolean(False, precedence=-1, doc="The message is one input's refusal, shown beside it.")
    extra_prediction = param.Dict(default={}, precedence=-1, doc="Predicted ratios of the run's extra filters.")

    def __init__(self, *, jobs: Jobs | None = None, **params) -> None:
        own = {k: v for k, v in params.items() if k in self.param}
        super().__init__(**own)
        #: the last α > 0 this page had (the default if it opened at α = 0): where unticking "α = 0" goes back to
        self.alpha_before_zero = self.alpha if self.alpha > 0.0 else self.param.alpha.default
        self.jobs = jobs or Jobs()
        self.started = False
        self._quiet = False  # set while the state itself corrects an input (no new run)
        self.shown_request: Request | None = None  # the request of the run on screen
        self.shown_inputs: dict | None = None  # the inputs of the run on screen, by key (RUN_KEYS)
        self._serial = 0
        self.baselines = BaselinesRoom(self)
        self.sweep = SweepRoom(self)
        self.worstcase = WorstCaseRoom(self)
        self.scenarios = ScenarioRoom(self)
        self.data = DataRoom(self)
        self.param.watch(self._on_inputs, list(INPUTS))
        self.baselines.param.watch(self._on_extra_inputs, list(self.baselines.KEYS.values()))
        self._key_of = {(id(self.owner(k)[0]), self.owner(k)[1]): k for k in ALL_INPUTS}  # (holder, name) → key
        self.watch(self._on_any_input, ALL_INPUTS)
        if rest := {k: v for k, v in params.items() if k not in own}:  # inputs of the rooms, by key
            self.set_inputs(rest)

    # ---- every input by its key -------------------------------------------------------------------------
    def owner(self, key: str) -> tuple[param.Parameterized, str]:
        """The object holding input ``key`` (this state or one of its rooms) and the parameter's name there."""
        attr, name = OWNERS[key]
        return (self if attr is None else getattr(self, attr)), name

    def get(self, key: str):
        """The value of input ``key``."""
        obj, name = self.owner(key)
        return getattr(obj, name)

    def watch(self, fn, keys) -> None:
        """Call ``fn(*events)`` when any of the inputs ``keys`` changes (one watcher per room)."""
        by_owner: dict[int, tuple[param.Parameterized, list[str]]] = {}
        for key in keys:
            obj, name = self.owner(key)
            by_owner.setdefault(id(obj), (obj, []))[1].append(name)
        for obj, names in by_owner.values():
            obj.param.watch(fn, names)

    @contextlib.contextmanager
    def batch(self):
        """Changes made inside reach the watchers of this state and of every room once, at the end."""
        with contextlib.ExitStack() as stack:
            for obj in (self, *self.rooms()):
                stack.enter_context(param.parameterized.batch_call_watchers(obj))
            yield

    def rooms(self) -> tuple[Room, ...]:
        """The session's rooms, in the order of :data:`ROOMS`."""
        return tuple(getattr(self, attr) for attr in ROOMS)

    # ---- the boundary: values from outside ------------------------------------------------------------
    def set(self, key: str, value) -> bool:
        """Assign input ``key`` a value from outside (a widget): one the declaration refuses is refused beside the
        input, in words naming it and its range, and the last good run stays on screen. Whether it was taken."""
        text = self._assign(key, value, {})
        if text is None:  # its refusal was lifted as it was assigned (a refused run may have put a new one since)
            return True
        kept = "The last good run is kept." if self.run is not None else "Nothing was simulated for it."
        self.say(f"Refused: {text}. {kept}", "danger", inline=True)
        self.refusals = {key: f"Refused: {text}. {kept}"}
        return False

    def _assign(self, key: str, value, pending: dict, link: bool = False) -> str | None:
        """Assign input ``key``; None, or why it was refused (in words, :func:`app.inputs.refusal`). ``pending``: the
        other values set with it (the σ range's ends are judged as they will be)."""
        obj, name = self.owner(key)
        p = obj.param[name]
        value = inputs.shape(p, value)
        if key in SIGMA_ENDS and isinstance(value, float) and math.isfinite(value):
            ends: dict[str, float] = {"sigma_min": self.baselines.sigma_min, "sigma_max": self.baselines.sigma_max}
            ends.update({k: v for k, v in pending.items() if isinstance(v, int | float) and not isinstance(v, bool)})
            ends[key] = value
            try:  # the σ range stays a range: a combination of two inputs, judged with both as they will be
                check_order(ends["sigma_min"], ends["sigma_max"])
            except ValueError as exc:
                return str(exc)
        self._lift(key)  # before the input's watchers run: a computation they start sees no refusal of it
        try:
            setattr(obj, name, value)
        except ValueError:
            return inputs.refusal(p, value, input_label(key, link))
        return None

    def _lift(self, *keys: str) -> None:
        """Inputs ``keys`` hold a good value again: their refusals go (and the message, with the last of them)."""
        if any(key in self.refusals for key in keys):
            left = {k: v for k, v in self.refusals.items() if k not in keys}
            if left:
                self.refusals = left
            else:
                self._clear()

    def _on_any_input(self, *events) -> None:
        """An input changed in code (a recommendation, a button): it holds a good value, so its refusal goes — unless a
        refused run has already taken it back (its refusal then stands)."""
        now = [self._key_of[id(e.obj), e.name] for e in events if getattr(e.obj, e.name) == e.new]
        self._lift(*now)
        if any(e.name == "alpha" and e.obj is self for e in events) and self.alpha > 0.0:
            self.alpha_before_zero = self.alpha

    def set_inputs(self, values: dict, problems: dict[str, str] | None = None, *, link: bool = False) -> list[str]:
        """Set every good value of ``values`` (by key) in one batch (one new run); report every bad one, and those in
        ``problems`` (key → message, e.g. a link's unreadable values), in ONE message. Returns the reports.

        ``link``: the values come from a URL (messages then give each input's name in links too)."""
        bad = dict(problems or {})
        with self.batch():
            for key, value in values.items():
                text = self._assign(key, value, {k: v for k, v in values.items() if k in SIGMA_ENDS}, link)
                if text is not None:
                    bad[key] = text
        if bad:
            kept = "the last good run is kept" if self.run is not None else "nothing was simulated for them"
            what = "a value" if len(bad) == 1 else f"{len(bad)} values"
            self.say(
                f"Refused {what} (each keeps its previous setting; {kept}): " + "; ".join(bad.values()) + ".", "danger"
            )
            self.refusals = {key: f"Refused: {text}." for key, text in bad.items() if key in OWNERS}
        return list(bad.values())

    def say(self, text: str, kind: str = "info", *, inline: bool = False) -> None:
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
        return self.jobs.busy("run")

    def submit(self, kind: str, fn, done, *, pool: str = "run") -> None:
        """``fn()`` off the event loop, then ``done(outcome, superseded)`` on it (:meth:`app.jobs.Jobs.submit`)."""
        self.jobs.submit(kind, fn, done, pool=pool)

    def refused_among(self, keys) -> str:
        """Why a computation over inputs ``keys`` does not start: one of them still shows a refused value."""
        bad = ", ".join(declaration(k).label for k in keys if k in self.refusals)
        return f"Not started: correct the refused value of {bad} first (it would use the previous one)." if bad else ""

    def later(self, fn) -> None:
        """Run ``fn()`` on the session's loop with its lock held (from any thread; at once outside a server)."""
        self.jobs.later(fn)

    def request(self) -> Request:
        """The run the inputs ask for."""
        extra = self.baselines
        return Request(
            self.alpha,
            self.beta_effective,
            self.sigma,
            self.nu,
            self.m,
            self.seed,
            self.horizon,
            tuple(extra.extra_filters),
            extra.sigma_design,
            extra.sigma_range,
        )

    # ---- runs ----------------------------------------------------------------------------------------
    def start(self) -> None:
        """Compute the first run and the sweep's theory curves, as jobs (in a served session: off the event loop).

        With no run on screen yet, a run too long for the dashboard is replaced by its nearest allowed setting (a
        shorter horizon, :func:`app.pipeline.fit`): a page opened from any link shows a run or says why it cannot."""
        self.started = True
        if self.alpha == 0.0 and self.beta_from_w:
            self._switch_to_beta()
        self.busy = True
        self.jobs.submit(
            "run",
            partial(compute, self.request(), nearest=True),
            partial(self._apply_run, self._serial, self.run_inputs()),
            cancellable=True,
        )
        self.sweep.refresh_curves()

    def _switch_to_beta(self) -> None:
        beta = self.run.model.beta if self.run is not None else self.beta
        beta = min(max(beta, self.param.beta.bounds[0]), self.param.beta.bounds[1])
        self.param.update(beta_from_w=False, beta=beta)
        self.say(f"α = 0: β = w√(2α) would vanish, so β is now set directly (β = {beta:.4g}).", "info")

    def _on_inputs(self, *events) -> None:
        if not self.started:
            return
        if self.alpha == 0.0 and self.beta_from_w:
            self._switch_to_beta()  # its own assignments come back here with a valid model
            return
        if self._quiet:
            return
        self.busy = not self.live  # a small run is back before a spinner could be seen
        nearest = self.run is None  # nothing on screen to keep: show the nearest allowed setting instead
        self.jobs.submit(
            "run",
            partial(compute, self.request(), nearest=nearest),
            partial(self._apply_run, self._serial, self.run_inputs()),
            pool="run" if self.live else "large",
            cancellable=True,
        )

    def _on_extra_inputs(self, *events) -> None:
        """σ̄ and the σ range change the run only when an extra filter is drawn (or the selection changed)."""
        if self.baselines.extra_filters or any(e.name == "extra_filters" for e in events):
            self._on_inputs(*events)

    def run_inputs(self) -> dict:
        """The inputs a run is made of, by key (:data:`app.state.refused_run.RUN_KEYS`)."""
        return {key: self.get(key) for key in RUN_KEYS}

    def _apply_run(self, serial: int, asked: dict, outcome: Outcome, superseded: bool) -> None:
        if outcome.error is not None:
            if not superseded:
                refuse_run(self, asked, outcome.error)
            self.busy = superseded
            return
        res: Result = outcome.value
        if res.adjusted and not superseded:
            self._quiet = True  # the input now shows what was simulated; that starts no second run
            try:
                self.param.update(horizon=res.request.horizon)
            finally:
                self._quiet = False
        self.shown_request, self.shown_inputs = res.request, {**asked, "horizon": res.request.horizon}
        self.param.update(
            run=res.run,
            traces=res.traces,
            prediction=res.prediction,
            extra_prediction=res.extra_prediction or {},
            compute_seconds=outcome.seconds,
            busy=superseded,
        )
        if res.adjusted and not superseded:
            self.say(f"Showing the nearest allowed setting: {res.adjusted}.", "warning")
        elif serial == self._serial and (not self.refusals or run_refusal_shown(self)):
            self._clear()

    def restore(self, values: dict) -> None:
        """Set inputs (by key) back to the values of the run on screen: no new run (it is that run)."""
        self._quiet = True
        try:
            self.set_inputs(values)
        finally:
            self._quiet = False

    def apply_preset(self, name: str) -> None:
        """Set the inputs of preset ``name`` (see :mod:`app.presets`) in one batch: one new run."""
        if name not in PAPER_PRESETS:
            self.say(f"Unknown preset {name!r}; choose one of {', '.join(PAPER_PRESETS)}.", "danger")
            return
        self._clear()
        self.set_inputs(PAPER_PRESETS[name].values)

    def csv(self) -> io.StringIO:
        """The run on screen as CSV (:func:`app.export.run_csv`), for the download button."""
        return io.StringIO(run_csv(self))

    def png(self) -> io.BytesIO:
        """The run on screen as a PNG figure (:func:`app.export.run_png`), for the download button."""
        if self.run is None:
            raise ValueError("there is no run to draw yet")
        return run_png(self.run)

    def describe(self, error: BaseException) -> str:
        """A job's failure in words for the page (tracebacks go to the server log)."""
        return describe(error)

    def close(self) -> None:
        """End of the session: stop its long job, drop pending work and the large arrays."""
        self.jobs.close()
        with param.parameterized.discard_events(self):  # the views are going away: no redraw
            self.param.update(run=None, traces=None, prediction=None, extra_prediction={})
        for room in self.rooms():
            if hasattr(room, "release"):
                room.release()
