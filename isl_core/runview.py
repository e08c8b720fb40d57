"""A run for display: its trajectories decimated while it is simulated, in memory that does not grow with its length.

:func:`simulate_view` simulates exactly what :func:`isl_core.simulate` does (same grid, same noise, same start,
bit for bit) but never holds the trajectories: the kernel writes each chunk of ``chunk`` steps to small buffers and
the min/max reducer of :mod:`isl_core.decimate` keeps, per trace, at most ``points`` samples — the envelope a plot
can show. A 10⁶-step run at m = 6 with six filters then needs ≈ 10 MB instead of 336 MB.

Per coordinate i it keeps the truth X_i, every filter's estimate Z_f,i = X_i + e_f,i and its error e_f,i (the error
view), an adaptive filter's σ̂; and it measures, over every step k = 1..N, each filter's RMSE (A.30) and the share
of steps with ``|e_f,i| ≤ 3 s_i`` — for the optimal filter, the share of time the signal spends inside the tube
X̂_i ± 3 s_i, which theory puts at 99.73 % (a Gaussian error of standard deviation s_i).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ._engine import Tracked, check_progress, check_start, freeze, run_chunks
from .bounds import BOUNDS
from .decimate import DISPLAY_POINTS, MinMax
from .filters.base import KIND_ADAPTIVE, FilterSpec
from .filters.kalman import optimal_kbf
from .grid import check_filters, run_plan
from .kernels.bundles import Buckets, Trajectory, Tube
from .kernels.euler import minmax_block
from .model import Model
from .riccati import kalman_bucy
from .validate import check_int

__all__ = ["DISPLAY_CHUNK", "TUBE_THEORY", "RunView", "Trace", "TrackView", "simulate_view"]

DISPLAY_CHUNK = 1 << 14  #: steps per kernel call of a display run (its buffers: 8·(1 + 2·filters)·m bytes a step)
TUBE_THEORY = math.erf(3.0 / math.sqrt(2.0))  #: P(|U| ≤ 3) = 0.9973 for U ~ N(0, 1): a ±3 s tube's share


@dataclass(frozen=True)
class Trace:
    """A decimated trace: the times ``t`` and values ``y`` of the samples kept (real samples, in time order)."""

    t: np.ndarray
    y: np.ndarray


@dataclass(frozen=True)
class TrackView:
    """One filter of a :class:`RunView`: per coordinate its decimated estimate and error, its RMSE over every step
    (A.30) and ratio to s_i, and ``inside`` (m,), the share of steps with ``|e_i| ≤ 3 s_i``; ``sigma_hat`` the
    decimated σ̂ of an adaptive filter and ``sigma_hat_mean`` its mean over the steps k = 1..N (None otherwise)."""

    name: str
    label: str
    estimate: tuple[Trace, ...]
    error: tuple[Trace, ...]
    rmse: np.ndarray
    ratio: np.ndarray
    inside: np.ndarray
    sigma_hat: Trace | None = None
    sigma_hat_mean: float | None = None


@dataclass(frozen=True)
class RunView(Tracked[TrackView]):
    """A simulated run, decimated for display: ``truth`` (per coordinate), ``tracks`` (Kalman–Bucy, ISL, extras).

    The same fields as :class:`isl_core.Run` where they are numbers (``s``, ``r_min``, ``h``, ``T``, ``N``,
    ``stretch``, ``start``); ``points``: at most that many samples per trace.
    """

    model: Model
    nu: float
    seed: int
    N: int
    h: float
    T: float
    r_min: float
    s: np.ndarray
    stretch: float
    start: str
    truth: tuple[Trace, ...]
    tracks: tuple[TrackView, ...]
    points: int


class _Collector:
    """Folds each chunk into the min/max buckets — truth, estimates, errors, σ̂ as columns — and counts the steps
    inside the tube, in compiled code that releases the GIL (:func:`isl_core.kernels.minmax_block`): a display run
    then leaves the server's other threads (its event loop included) free while it reduces its chunks."""

    def __init__(self, n: int, m: int, nf: int, na: int, s: np.ndarray, points: int) -> None:
        self.n = n + 1
        self.reducer = MinMax(self.n, m * (1 + 2 * nf) + na, points)
        self.bound = 3.0 * np.asarray(s, dtype=float)
        self.inside = np.zeros((nf, m), np.int64)
        self.sigma_sum = np.zeros(na)

    def __call__(self, X: np.ndarray, E: np.ndarray, S: np.ndarray) -> None:
        buckets = Buckets(self.reducer.size, *self.reducer.state)
        tube = Tube(self.bound, self.inside, self.sigma_sum)
        minmax_block(X, E, S, self.reducer.seen, self.n, buckets, tube)  # steps k ≥ 1 counted: the RMSE's k = 1..N
        self.reducer.advanced(len(X))

    def trace(self, column: int, h: float) -> Trace:
        idx, val = self.reducer.result(column)
        return Trace(freeze(idx * h), freeze(val))


def simulate_view(
    model: Model,
    nu: float,
    *,
    horizon: float = 10.0,
    T: float | None = None,
    h: float | None = None,
    seed: int = 0,
    extra: Sequence[FilterSpec] = (),
    step_filters: Sequence[FilterSpec] = (),
    start: str = "stationary",
    points: int = DISPLAY_POINTS,
    progress: Callable[[float], None] | None = None,
) -> RunView:
    """:func:`isl_core.simulate` (same arguments, same run bit for bit) decimated to ``points`` samples per trace
    on the fly (module docstring). Raises what ``simulate`` raises."""
    plan = run_plan(model, nu, horizon=horizon, T=T, h=h, extra=extra, step_filters=step_filters)
    seed = BOUNDS.seed.whole(seed)
    points = check_int("points", points, lo=4, hi=10**6)
    start = check_start(start)
    check_progress(progress)
    kb = kalman_bucy(model)
    filters = [optimal_kbf(model, kb), *check_filters(model, nu, extra)]
    m, nf, n = model.m, len(filters), plan.N
    adaptive = [f for f, spec in enumerate(filters) if spec.kind == KIND_ADAPTIVE]
    rows = min(DISPLAY_CHUNK, n) + 1
    X, E, S = np.empty((rows, m)), np.empty((nf, rows, m)), np.empty((len(adaptive), rows))
    collect = _Collector(n, m, nf, len(adaptive), np.asarray(kb.s), points)
    sq, _, _ = run_chunks(
        model,
        kb,
        filters,
        plan.h,
        n,
        seed,
        start=start,
        burn=0,
        batches=1,
        out=Trajectory(True, 0, X, E, S),
        progress=progress,
        on_block=collect,
        chunk=DISPLAY_CHUNK,
    )
    s = freeze(np.array(kb.s))
    truth = tuple(collect.trace(i, plan.h) for i in range(m))
    tracks = []
    for f, spec in enumerate(filters):
        rmse = np.sqrt(sq[0, f] / n)  # (A.30)
        est = tuple(collect.trace(m * (1 + f) + i, plan.h) for i in range(m))
        err = tuple(collect.trace(m * (1 + nf + f) + i, plan.h) for i in range(m))
        sig = mean = None
        if f in adaptive:
            sig = collect.trace(m * (1 + 2 * nf) + adaptive.index(f), plan.h)
            mean = float(collect.sigma_sum[adaptive.index(f)] / n)
        tracks.append(
            TrackView(
                spec.name,
                spec.label,
                est,
                err,
                freeze(rmse),
                freeze(rmse / s),
                freeze(collect.inside[f] / n),
                sig,
                mean,
            )
        )
    return RunView(
        model, float(nu), seed, n, plan.h, plan.T, kb.r_min, s, plan.stretch, start, truth, tuple(tracks), points
    )
