"""Simulation of the truth and the filters on one Euler grid (B.30–B.34, A.18, A.29–A.30, :ref:`simulation`,
:ref:`error-coordinates`).

The truth is simulated by Euler–Maruyama **on the filters' grid** (B.33–B.34): an exact-in-continuous-time
truth would make ΔY/h the step average of X_1 and bias every Euler filter by ≈ (h/2)·X_2 (:ref:`euler-pitfall`). The
filters
are integrated in error coordinates e = Z − X (:ref:`error-coordinates`, :mod:`isl_core.kernels`): their errors keep
every digit
whatever the size of the signal; the estimates are rebuilt as ``Z = X + e`` for display only.

Step size (B.47) and length (B.46): :mod:`isl_core.grid`.

Start (:ref:`start`): the truth at X(0) = 0 except X_m(0) ~ N(0, β²/(2α)) when α > 0; every filter at
``Z(0) = X(0) − e₀`` with ONE common draw ``e₀ ~ N(0, Δ)`` (``start="stationary"``): the optimal filter's error is
then stationary from t = 0, so its measured ratio is ≈ 1 at any horizon. ``start="truth"`` starts every filter at
the truth, with no start error (its measured ratio is then below 1 on short runs).

Readings (``readings=True``, :ref:`data-readings`): what the filters took in, as a recorded series holds it — at each
kept time t_k after the first, the observation's average over the interval since the previous kept time,
``z_k = (Y(t_k) − Y(t_{k−1}))/(t_k − t_{k−1})`` with ``ΔY = X_1·h + σ√h·ε`` per step (B.34). The kernel draws ε
and never forms Y; the readings replay the same stream of the same seed (the start's draws, then the rows
(v_k, ε_k): :func:`isl_core._engine.draw_noise`), so they are the noise the filters saw.

Empirical RMSE along one trajectory (A.30): ``š_i = √(mean_{k=1..N} (Z_i(t_k) − X_i(t_k))²)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ._engine import CHUNK, DivergenceError, Tracked, check_progress, check_start, draw_start, freeze, run_chunks
from .bounds import BOUNDS
from .filters.base import KIND_ADAPTIVE, FilterSpec
from .filters.kalman import optimal_kbf
from .grid import check_filters, run_plan
from .kernels.bundles import Trajectory
from .model import Model
from .riccati import KalmanBucy, kalman_bucy
from .validate import check_int

__all__ = ["DivergenceError", "Run", "Track", "simulate"]


@dataclass(frozen=True)
class Track:
    """One filter along a run: its error ``e = Z − X`` (N+1, m), its empirical RMSE (A.30) and ratio ``š_i/s_i``.

    ``estimate`` is ``X + e`` (rebuilt on access, for display). ``sigma_hat`` (N+1,): an adaptive filter's online
    estimate σ̂(t_k) (σ̂(0) its initial value); None otherwise.
    """

    name: str
    label: str
    error: np.ndarray
    rmse: np.ndarray
    ratio: np.ndarray
    sigma_hat: np.ndarray | None = None
    truth: np.ndarray | None = field(default=None, repr=False, compare=False)

    @property
    def estimate(self) -> np.ndarray:
        """The estimate ``Z = X + e`` (N+1, m), read-only."""
        return freeze(self.truth + self.error)


@dataclass(frozen=True)
class Run(Tracked[Track]):
    """One simulated trajectory with the optimal and the ISL filter (and any extra filters).

    ``t`` (K,), ``X`` truth (K, m) at the kept steps — every ``every``-th of the N + 1 (all of them by default) —,
    ``tracks`` in order: Kalman–Bucy, ISL, extras; their RMSE and ratios are over every step k = 1..N.
    ``s = √diag Δ`` (theory, A.29–A.30), ``r_min`` (A.24), ``h`` step, ``T = N·h``. ``stretch = r_min / r``
    with r the settling rate of the optimal and the ISL filter (≥ 1; T = horizon/r when the horizon was given in
    units of 1/r_min), ``start`` how the filters started (:data:`!STARTS`). ``readings`` (K,): the observation's
    average over the interval before each kept time (NaN at t = 0; module docstring), when asked for.
    """

    model: Model
    nu: float
    seed: int
    t: np.ndarray
    X: np.ndarray
    tracks: tuple[Track, ...]
    s: np.ndarray
    r_min: float
    h: float
    T: float
    stretch: float = 1.0
    start: str = "stationary"
    every: int = 1
    readings: np.ndarray | None = field(default=None, repr=False, compare=False)

    @property
    def N(self) -> int:
        """Steps simulated (T = N·h)."""
        return round(self.T / self.h)

    X_hat = property(lambda self: self.tracks[0].estimate, doc="Kalman–Bucy estimate X̂ (N+1, m)")
    X_check = property(lambda self: self.tracks[1].estimate, doc="ISL estimate X̌ (N+1, m)")
    s_hat = property(lambda self: self.tracks[0].rmse, doc="empirical RMSE ŝ_i of X̂ (A.30)")
    s_check = property(lambda self: self.tracks[1].rmse, doc="empirical RMSE š_i of X̌ (A.30)")


def simulate(
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
    every: int = 1,
    readings: bool = False,
    progress: Callable[[float], None] | None = None,
) -> Run:
    """Simulate truth, the optimal Kalman–Bucy filter and the ISL filter with tuning ``nu`` on one grid.

    Length: ``T`` (absolute) if given, else ``horizon`` in units of 1/r_min (A, Fig. 3: 10), lengthened by
    ``stretch = r_min / settling_rate`` when the ISL filter settles slower than the optimal one (module
    docstring). ``h`` by :func:`step_size` over every filter simulated and ``step_filters`` — filters that are not
    simulated but must not change the grid when they are (e.g. those a view can show on demand). ``seed`` (int ≥ 0)
    fixes the noise: the same seed gives the same run, bit for bit. ``extra`` filters ride on the same noise.
    ``start``: :data:`!STARTS`. ``every``: keep the trajectories at every ``every``-th step only (memory ÷ every;
    the RMSE still counts every step). ``readings``: also the readings the filters took in (module docstring).
    ``progress(fraction)`` is called between kernel chunks; raising from it
    cancels. Raises ``ValueError`` for bad input or too many steps, :class:`DivergenceError` for a blown-up filter.

    Parameters
    ----------
    model : Model
        The model (truth and optimal filter).
    nu : float
        The ISL filter's tuning ν > 0.
    horizon : float, default 10.0
        Length in units of 1/r_min (ignored when ``T`` is given).
    T, h : float, optional
        Absolute length and step (default: as above, and :func:`step_size`).
    seed : int, default 0
        The noise.
    extra, step_filters : sequence of FilterSpec
        More filters on the same noise; filters that only count for the step size.
    start : str, default "stationary"
        How the filters start (:data:`!STARTS`).
    every : int, default 1
        Keep every ``every``-th step of the trajectories.
    readings : bool, default False
        Also the readings, ``Run.readings``.
    progress : callable, optional
        Called with the fraction done.

    Returns
    -------
    Run
        Truth ``X``, the filters' ``tracks`` (Kalman–Bucy, ISL, extras), their RMSEs and ratios, ``r_min``, ``h``,
        ``T``, ``N``.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import Model, simulate
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> run = simulate(model, nu=model.beta, horizon=2.0, seed=1)
    >>> [track.name for track in run.tracks], run.ratio_hat.shape
    (['kbf', 'isl'], (3,))
    >>> bool(np.array_equal(simulate(model, nu=model.beta, horizon=2.0, seed=1).X, run.X))  # same seed, same run
    True
    """
    plan = run_plan(model, nu, horizon=horizon, T=T, h=h, extra=extra, step_filters=step_filters)
    seed = BOUNDS.seed.whole(seed)
    every = check_int("every", every, lo=1)
    start = check_start(start)
    check_progress(progress)
    kb = kalman_bucy(model)
    filters = [optimal_kbf(model, kb), *check_filters(model, nu, extra)]
    T, h, n, stretch = plan.T, plan.h, plan.N, plan.stretch
    observed = _Readings(model, kb, seed, start, n, h, every) if readings else None
    sq, X, E, S, kept = _trajectories(model, kb, filters, h, n, seed, start, every, progress, observed)
    s = freeze(kb.s.copy())
    X = freeze(X)
    tracks = _tracks(filters, sq, n, E, S, X, s)
    t = kept.astype(np.float64)
    t *= h
    t = freeze(t)
    z = None if observed is None else freeze(observed.result(kept))
    return Run(model, float(nu), seed, t, X, tracks, s, kb.r_min, h, T, stretch, start, every, z)


def _trajectories(
    model: Model,
    kb: KalmanBucy,
    filters: Sequence[FilterSpec],
    h: float,
    n: int,
    seed: int,
    start: str,
    every: int,
    progress: Callable[[float], None] | None,
    observed: _Readings | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One run of ``filters``: squared-error sums ``sq``, truth ``X``, errors ``E``, adaptive σ̂ ``S`` at the kept
    steps ``kept`` (every ``every``-th; all of them at once, or thinned chunk by chunk)."""
    na = sum(spec.kind == KIND_ADAPTIVE for spec in filters)
    if every == 1:
        X, E, S = np.empty((n + 1, model.m)), np.empty((len(filters), n + 1, model.m)), np.empty((na, n + 1))
        sq, _, _ = run_chunks(
            model,
            kb,
            filters,
            h,
            n,
            seed,
            start=start,
            burn=0,
            batches=1,
            out=Trajectory(True, 0, X, E, S),
            progress=progress,
        )
        if observed is not None:
            for k in range(0, n + 1, CHUNK):
                observed(X[k : k + CHUNK])
        return sq, X, E, S, np.arange(n + 1)
    keep = _Stride(every, n, model.m, len(filters), na, observed)
    rows = min(CHUNK, n) + 1
    buffers = Trajectory(
        True, 0, np.empty((rows, model.m)), np.empty((len(filters), rows, model.m)), np.empty((na, rows))
    )
    sq, _, _ = run_chunks(
        model, kb, filters, h, n, seed, start=start, burn=0, batches=1, out=buffers, progress=progress, on_block=keep
    )
    return sq, keep.X, keep.E, keep.S, keep.index


def _tracks(
    filters: Sequence[FilterSpec],
    sq: np.ndarray,
    n: int,
    E: np.ndarray,
    S: np.ndarray,
    X: np.ndarray,
    s: np.ndarray,
) -> tuple[Track, ...]:
    """Each filter's :class:`Track`: its errors, RMSE (A.30) and ratios, and σ̂ for an adaptive one."""
    tracks = []
    sigma_hat = iter(S)
    for f, spec in enumerate(filters):
        rmse = np.sqrt(sq[0, f] / n)  # (A.30)
        sig = freeze(next(sigma_hat)) if spec.kind == KIND_ADAPTIVE else None
        tracks.append(Track(spec.name, spec.label, freeze(E[f]), freeze(rmse), freeze(rmse / s), sig, X))
    return tuple(tracks)


class _Stride:
    """Keeps the samples k = 0, every, 2·every, … of the chunks :func:`run_chunks` hands over."""

    def __init__(self, every: int, n: int, m: int, nf: int, na: int, observed: _Readings | None = None) -> None:
        self.every, self.seen, self.observed = every, 0, observed
        self.index = np.arange(0, n + 1, every)
        self.X, self.E, self.S = (
            np.empty((len(self.index), m)),
            np.empty((nf, len(self.index), m)),
            np.empty((na, len(self.index))),
        )

    def __call__(self, X: np.ndarray, E: np.ndarray, S: np.ndarray) -> None:
        k0, k1 = self.seen, self.seen + len(X)
        rows = np.arange(-(-k0 // self.every) * self.every, k1, self.every)  # kept samples in [k0, k1)
        at = rows // self.every
        self.X[at], self.E[:, at], self.S[:, at] = X[rows - k0], E[:, rows - k0], S[:, rows - k0]
        self.seen = k1
        if self.observed is not None:
            self.observed(X)


class _Readings:
    """Sums ΔY = X_1·h + σ√h·ε_k (B.34) of the steps between kept times, ε_k replayed from the seed (module
    docstring); called with the truth at consecutive samples, from sample 0 on (step k starts at sample k)."""

    def __init__(self, model: Model, kb: KalmanBucy, seed: int, start: str, n: int, h: float, every: int) -> None:
        self.rng = np.random.default_rng(seed)
        draw_start(model, kb, self.rng, start)  # the start's draws come first in the stream
        self.sigma_sqh, self.h, self.n, self.every, self.seen = model.sigma * math.sqrt(h), h, n, every, 0
        self.sums = np.zeros(n // every + 2)

    def __call__(self, X: np.ndarray) -> None:
        k0 = self.seen
        steps = max(0, min(k0 + len(X), self.n) - k0)  # samples n and beyond start no step
        if steps:
            eps = self.rng.standard_normal((steps, 2))[:, 1]  # rows (v_k, ε_k), as the kernel draws them
            dy = self.h * X[:steps, 0] + self.sigma_sqh * eps
            np.add.at(self.sums, np.arange(k0, k0 + steps) // self.every + 1, dy)  # step k ends in row k//every + 1
        self.seen = k0 + len(X)

    def result(self, kept: np.ndarray) -> np.ndarray:
        """The readings at the kept samples ``kept`` (NaN at the first)."""
        z = np.full(len(kept), np.nan)
        z[1:] = self.sums[1 : len(kept)] / (np.diff(kept) * self.h)
        return z
