"""The ν-sweep's room (paper A's Fig. 2): its σ values and horizon, the theory curves, the simulated points and the
recommended ν.

The curves (:func:`app.sweeps.theory_curves`) are computed once the sweep's tab is open and again whenever their
context — α, β, m, the sweep's σ values, the extra filters — changes; simulated points and recommendations are the
session's long jobs (:class:`app.jobs.LongTask`). A recommendation sets the model's ν.
"""

from __future__ import annotations

from functools import partial
from typing import ClassVar

import param

from isl_core import BOUNDS

from .. import sweeps
from ..inputs import Real, Reals
from ..jobs import Outcome
from ..text import R_MIN
from .room import LongJobRoom

__all__ = ["SWEEP_SIGMA_BOUNDS", "SweepRoom"]

SWEEP_SIGMA_BOUNDS = BOUNDS.sigma.range  #: each σ of the sweep: the dashboard's σ range
_LO, _HI = SWEEP_SIGMA_BOUNDS
#: the model's inputs that change the sweep's context (its curves and which points are still valid)
CONTEXT = ("alpha", "beta_from_w", "w", "beta", "m")


class SweepRoom(LongJobRoom):
    """Inputs, curves, points and jobs of the ν-sweep (the module docstring); keys ``sweep_…``."""

    KEYS: ClassVar[dict[str, str]] = {"sweep_sigmas": "sigmas", "sweep_horizon": "horizon"}

    sigmas = Reals(
        [2.0, 20.0, 200.0],
        item_bounds=SWEEP_SIGMA_BOUNDS,
        bounds=(1, 5),
        label="σ values",
        doc=(f"σ of the sweep's curves (1 to 5 values in [{_LO:g}, {_HI:g}]); paper A, Fig. 2: 2, 20, 200."),
    )
    horizon = Real(
        200.0,
        bounds=(20.0, 2000.0),
        label=f"sweep horizon (× 1/{R_MIN})",
        doc=(f"Length of each simulated sweep run in units of 1/{R_MIN}; ±2 % needs about 1000."),
    )

    curves = param.ClassSelector(class_=sweeps.SweepCurves, default=None, allow_None=True, precedence=-1)
    curves_note = param.String("", precedence=-1, doc="Why there are no theory curves, if there are none.")
    points = param.ClassSelector(class_=sweeps.SweepPoints, default=None, allow_None=True, precedence=-1)

    def __init__(self, host, **params) -> None:
        super().__init__(host, **params)
        self._wanted = False  # the theory curves: computed once the sweep's tab is open
        self._note_context: tuple | None = None  # the sweep context (α, β, m, σs) that ``note`` reports on
        host.param.watch(self._on_context, list(CONTEXT))
        host.baselines.param.watch(self._on_context, list(host.baselines.KEYS.values()))
        self.param.watch(self._on_context, ["sigmas"])

    def model(self) -> tuple[float, float, int, tuple[float, ...]]:
        """The sweep's context: α, β, m and its σ values."""
        host = self._host
        return host.alpha, host.beta_effective, host.m, tuple(self.sigmas)

    def want_curves(self) -> None:
        """The ν-sweep is on screen: compute its theory curves, now and whenever their context changes (a session
        that never opens that tab never computes them)."""
        if not self._wanted:
            self._wanted = True
            if self._host.started:
                self.refresh_curves()

    def _on_context(self, *events) -> None:
        if self._host.started:
            self._drop_stale()
            if self._wanted:
                self.refresh_curves()

    def _drop_stale(self) -> None:
        """Simulated points and a status note of another context (α, β, m, sweep σ) go stale."""
        key = self.model()
        pts = self.points
        if pts is not None and (pts.alpha, pts.beta, pts.m, pts.sigmas) != key:
            self.points = None
        if not self.busy and self._note_context not in (None, key):  # the note spoke of another context
            self.note, self._note_context = "", None

    def refresh_curves(self) -> None:
        """Theory curves for the current α, β, m and sweep σ (if the tab was opened)."""
        if not self._wanted:
            return
        extra = self._host.baselines
        self.jobs.submit(
            "theory",
            partial(
                sweeps.theory_curves,
                *self.model(),
                extras=tuple(extra.extra_filters),
                sigma_design=extra.sigma_design,
                sigma_range=extra.sigma_range,
            ),
            self._apply_curves,
        )

    def _apply_curves(self, outcome: Outcome, superseded: bool) -> None:
        if outcome.error is None:
            self.param.update(curves=outcome.value, curves_note="")
        elif not superseded:
            self.param.update(curves=None, curves_note=f"No theory curves: {self.describe(outcome.error)}.")

    def simulate(self) -> None:
        """Simulate the sweep's points for the current context (progress in ``progress``; cancellable)."""
        if blocked := self.refused_among(self.KEYS):
            self.note = blocked
            return
        alpha, beta, m, sigmas = self.model()
        fn = partial(sweeps.simulate_points, alpha, beta, m, sigmas, horizon=self.horizon, seed=self._host.seed)
        self._task.start(
            fn, self._apply_points, f"Simulating {len(sigmas)} × {len(sweeps.SIM_LEVELS)} configurations …"
        )

    def _apply_points(self, outcome: Outcome) -> None:
        pts: sweeps.SweepPoints = outcome.value
        if (pts.alpha, pts.beta, pts.m, pts.sigmas) != self.model():
            self.note = "The parameters changed while the sweep ran; run it again."
        else:
            self._note_context = self.model()
            self.param.update(points=pts, note=sweeps.points_note(pts, outcome.seconds))

    def recommend(self) -> None:
        """Set ν to the value minimizing the worst-case ratio over the sweep's σ (``recommend_nu``, verified)."""
        if blocked := self.refused_among(self.KEYS):
            self.note = blocked
            return
        alpha, beta, m, sigmas = self.model()
        fn = partial(sweeps.recommend, alpha, beta, m, sigmas, horizon=self.horizon, seed=self._host.seed)
        self._task.start(
            fn, self._apply_recommendation, "Searching the theory for the best ν, then checking it by simulation …"
        )

    def _apply_recommendation(self, outcome: Outcome) -> None:
        nu, text = outcome.value
        host = self._host
        host.nu = min(max(nu, host.param.nu.bounds[0]), host.param.nu.bounds[1])
        self._note_context = self.model()
        self.note = text

    def release(self) -> None:
        """The session ends: drop the curves and points without a redraw."""
        with param.parameterized.discard_events(self):
            self.param.update(curves=None, points=None)
