"""The dashboard's run pipeline: inputs → a :class:`Request` → (fitted to the step limit) → a :class:`Result`.

A request is what one displayed run needs (the model, ν, the seed, the horizon, the extra filters); :func:`fit`
lowers its horizon to the longest the dashboard allows when it would need too many steps; :func:`compute` simulates
it through the core (:func:`isl_core.runview.simulate_view`: decimated while it runs), with the theory's predicted
ratios beside it. Pure functions: they run on a worker thread (:mod:`app.jobs`) and touch no state.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass

import numpy as np

from isl_core import BOUNDS, DivergenceError, Model, predicted_ratios, run_plan
from isl_core.runview import RunView, simulate_view

from . import extras
from .extras import SIGMA_DESIGN, SIGMA_RANGE
from .jobs import Cancelled
from .text import R_MIN, num

__all__ = [
    "APP_MAX_STEPS",
    "COORDINATES",
    "HORIZON_BOUNDS",
    "LIVE_MAX_STEPS",
    "Request",
    "Result",
    "Traces",
    "compute",
    "describe",
    "extra_filters",
    "fit",
    "plan",
    "traces",
]

log = logging.getLogger("app.state")

APP_MAX_STEPS = 1_000_000  #: steps per displayed run (memory ≈ 72·m bytes a step: 216 MB at m = 3)
LIVE_MAX_STEPS = 50_000  #: runs up to this size follow a slider while it is dragged; larger ones on release
HORIZON_BOUNDS = BOUNDS.horizon.range  #: of a displayed run, in units of 1/r_min
COORDINATES = ("position", "velocity", "acceleration", "jerk", "snap", "crackle")  #: X_1 … X_6


@dataclass(frozen=True)
class Request:
    """One run to compute: the model, the ISL filter's ν, the seed and the horizon in units of 1/r_min."""

    alpha: float
    beta: float
    sigma: float
    nu: float
    m: int
    seed: int
    horizon: float
    extras: tuple[str, ...] = ()
    sigma_design: float = SIGMA_DESIGN
    sigma_range: tuple[float, float] = SIGMA_RANGE


@dataclass(frozen=True)
class Traces:
    """Display copies of a run, min/max-decimated while it was simulated (:mod:`isl_core.runview`):
    ``series[i][name] = (t, y)`` in float32.

    ``name`` is ``"truth"`` (X_i), ``"kbf"`` (X̂_i), ``"isl"`` (X̌_i) or an extra filter's name (:mod:`app.extras`);
    ``"error:" + name`` is that filter's error e_i = Z_i − X_i.
    """

    series: tuple[dict[str, tuple[np.ndarray, np.ndarray]], ...]


@dataclass(frozen=True)
class Result:
    """A computed run with its display traces and the theory's predicted ``š_i/s_i`` (B.48, :ref:`linearization`).

    ``request`` is what was simulated: the asked-for one, or its nearest allowed setting (``adjusted`` says what
    changed and why; empty if nothing did).
    """

    run: RunView
    traces: Traces
    prediction: np.ndarray
    extra_prediction: dict | None
    request: Request
    adjusted: str = ""


def traces(run: RunView) -> Traces:
    """The float32 copies the plots receive of a decimated run: X_i, every filter's estimate and error."""
    series = []
    for i in range(run.model.m):
        pairs = {"truth": run.truth[i]}
        for tr in run.tracks:
            pairs[tr.name] = tr.estimate[i]
            pairs[f"error:{tr.name}"] = tr.error[i]
        series.append({name: (p.t.astype(np.float32), p.y.astype(np.float32)) for name, p in pairs.items()})
    return Traces(tuple(series))


def extra_filters(req: Request, model: Model) -> tuple[list, list]:
    """The extra filters shown, and every one a view can show (they fix the grid: showing one changes nothing)."""
    extra = extras.extra_specs(model, req.nu, req.extras, req.sigma_design, req.sigma_range)
    every = extras.extra_specs(model, req.nu, extras.EXTRA_NAMES, req.sigma_design, req.sigma_range)
    return extra, every


def plan(req: Request):
    """The model, the extra filters shown, every one a view can show, and the run's plan."""
    model = Model(req.alpha, req.beta, req.sigma, req.m)
    extra, every = extra_filters(req, model)
    return model, extra, every, run_plan(model, req.nu, horizon=req.horizon, step_filters=every, cap=2**62)


def _floor_sig(x: float, digits: int = 3) -> float:
    """``x`` > 0 rounded DOWN to ``digits`` significant digits (714.28 gives 714)."""
    q = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return float(f"{math.floor(x / q) * q:.{digits}g}")


def fit(req: Request, planned=None) -> tuple[Request, str]:
    """``req`` itself if its run fits :data:`APP_MAX_STEPS`, else the same with the longest horizon that fits and a
    sentence saying so; ``ValueError`` if not even the shortest horizon fits (naming the inputs to change).
    ``planned``: :func:`plan` of ``req``, if the caller has it."""
    _, _, _, grid = planned or plan(req)
    if grid.N <= APP_MAX_STEPS:
        return req, ""
    shortest = HORIZON_BOUNDS[0]
    horizon = _floor_sig(req.horizon * APP_MAX_STEPS / grid.N * 0.999)  # N ∝ horizon (h does not change)
    if horizon < shortest:
        raise ValueError(
            f"this setting needs {grid.N * shortest / req.horizon:,.0f} steps even at the shortest horizon "
            f"({num(shortest)} × 1/{R_MIN}), over the dashboard's limit of {APP_MAX_STEPS:,}: the fastest filter "
            "forces a tiny step; lower ν or raise σ"
        )
    return (
        dataclasses.replace(req, horizon=horizon),
        f"horizon lowered from {num(req.horizon)} to {num(horizon)} × 1/{R_MIN}: the run needs {grid.N:,} steps, "
        f"over the dashboard's limit of {APP_MAX_STEPS:,}",
    )


def compute(req: Request, *, nearest: bool = False, progress=None) -> Result:
    """Simulate ``req`` (T = horizon/r_min, lengthened for a slower ISL filter; h by the rule of :ref:`step-size` over
    every filter a view can show, so that showing one changes neither the grid nor the noise), decimate it and predict
    its ratios.

    Raises ``ValueError`` when the run would exceed :data:`APP_MAX_STEPS` (with ``nearest``: first lowers the
    horizon to the longest that fits, :func:`fit`), :class:`DivergenceError` when a filter blows up.
    """
    adjusted = ""
    planned = plan(req)
    if nearest:
        req, adjusted = fit(req, planned)
        if adjusted:
            planned = plan(req)
    model, extra, every, grid = planned
    if grid.N > APP_MAX_STEPS:
        longest = req.horizon * APP_MAX_STEPS / grid.N
        raise ValueError(
            f"horizon = {req.horizon:g} needs {grid.N:,} steps here, over the dashboard's limit of "
            f"{APP_MAX_STEPS:,}; choose a horizon <= {longest:.3g}"
        )
    # the plan's step is the one simulate_view would choose (the same T, so the same N and h bit for bit): passing it
    # spares the step-size search over every filter, about a third of a run's time at the defaults
    run = simulate_view(
        model, req.nu, horizon=req.horizon, h=grid.h, seed=req.seed, extra=extra, step_filters=every, progress=progress
    )
    prediction = np.asarray(predicted_ratios(model, req.nu))
    return Result(run, traces(run), prediction, extras.extra_theory(model, extra), req, adjusted)


def describe(exc: BaseException) -> str:
    if isinstance(exc, (ValueError, DivergenceError, Cancelled)):
        return str(exc)
    log.error("unexpected error in a dashboard job", exc_info=exc)
    return f"internal error ({type(exc).__name__}); details are in the server log"
