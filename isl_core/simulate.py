"""Simulation of the truth and the filters on one Euler grid (B.30–B.34, A.18, A.29–A.30, SPEC §4, §8).

The truth is simulated by Euler–Maruyama **on the filters' grid** (B.33–B.34): an exact-in-continuous-time
truth would make ΔY/h the step average of X_1 and bias every Euler filter by ≈ (h/2)·X_2 (SPEC §4). The filters
are integrated in error coordinates e = Z − X (SPEC §8, :mod:`isl_core.kernels`): their errors keep every digit
whatever the size of the signal; the estimates are rebuilt as ``Z = X + e`` for display only.

Step size (B.47) and length (B.46): :mod:`isl_core.grid`.

Start (SPEC §4): the truth at X(0) = 0 except X_m(0) ~ N(0, β²/(2α)) when α > 0; every filter at
``Z(0) = X(0) − e₀`` with ONE common draw ``e₀ ~ N(0, Δ)`` (``start="stationary"``): the optimal filter's error is
then stationary from t = 0, so its measured ratio is ≈ 1 at any horizon. ``start="truth"`` starts every filter at
the truth, as the papers do (its measured ratio is then below 1 on short runs).

Empirical RMSE along one trajectory (A.30): ``š_i = √(mean_{k=1..N} (Z_i(t_k) − X_i(t_k))²)``.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .filters import KIND_ADAPTIVE, FilterSpec, optimal_kbf
from .grid import check_filters, run_plan
from .kernels import AD_INV_MEMORY, AD_INV_STEP, AD_LOG_SIGMA0, AD_SIGMA, AD_VAR, AD_WIDTH, advance
from .model import Model
from .riccati import KalmanBucy, kalman_bucy
from .validate import check_int, short

__all__ = [
    "CHUNK", "STARTS", "DivergenceError", "Run", "Track", "draw_noise", "initial_error", "initial_state", "simulate",
]

CHUNK = 1 << 17  #: steps per kernel call (progress reports and cancellation happen between calls)
STARTS = ("stationary", "truth")  #: how the filters start (module docstring)


class DivergenceError(ArithmeticError):
    """A filter (or the simulated truth) left the finite numbers; the message says which, when, and a likely fix."""


def _freeze(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


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
        return _freeze(self.truth + self.error)


class _Tracked:
    """What a run with ``tracks`` (Kalman–Bucy, ISL, extras), ``T`` and ``r_min`` answers, full or decimated
    (:class:`Run`, :class:`isl_core.runview.RunView`)."""

    @property
    def horizon(self) -> float:
        """T in units of 1/r_min (A.24)."""
        return self.T * self.r_min

    def track(self, name: str):
        for tr in self.tracks:
            if tr.name == name:
                return tr
        raise KeyError(f"no filter named {name!r} in this run; have {[tr.name for tr in self.tracks]}")

    ratio_hat = property(lambda self: self.tracks[0].ratio, doc="ŝ_i/s_i of the optimal filter (≈ 1 on long runs)")
    ratio_check = property(lambda self: self.tracks[1].ratio, doc="š_i/s_i of the ISL filter")


@dataclass(frozen=True)
class Run(_Tracked):
    """One simulated trajectory with the optimal and the ISL filter (and any extra filters).

    ``t`` (K,), ``X`` truth (K, m) at the kept steps — every ``every``-th of the N + 1 (all of them by default) —,
    ``tracks`` in order: Kalman–Bucy, ISL, extras; their RMSE and ratios are over every step k = 1..N.
    ``s = √diag Δ`` (theory, A.29–A.30), ``r_min`` (A.24), ``h`` step, ``T = N·h``. ``stretch = r_min / r``
    with r the settling rate of the optimal and the ISL filter (≥ 1; T = horizon/r when the horizon was given in
    units of 1/r_min), ``start`` how the filters started (:data:`STARTS`).
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

    @property
    def N(self) -> int:
        """Steps simulated (T = N·h)."""
        return round(self.T / self.h)

    X_hat = property(lambda self: self.tracks[0].estimate, doc="Kalman–Bucy estimate X̂ (N+1, m)")
    X_check = property(lambda self: self.tracks[1].estimate, doc="ISL estimate X̌ (N+1, m)")
    s_hat = property(lambda self: self.tracks[0].rmse, doc="empirical RMSE ŝ_i of X̂ (A.30)")
    s_check = property(lambda self: self.tracks[1].rmse, doc="empirical RMSE š_i of X̌ (A.30)")


def draw_noise(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` rows of (v_k, ε_k) ~ N(0, 1): column 0 drives the signal (B.33), column 1 the observation (B.34).

    The compiled kernel draws the same stream from the same generator, one number at a time.
    """
    return rng.standard_normal((n, 2))


def initial_state(model: Model, rng: np.random.Generator) -> np.ndarray:
    """Truth at t = 0: zero except X_m(0) ~ N(0, β²/(2α)) when α > 0 (SPEC §4)."""
    x = np.zeros(model.m)
    if model.alpha > 0.0:
        x[-1] = math.sqrt(model.stationary_var) * rng.standard_normal()
    return x


def _cholesky(delta: np.ndarray) -> np.ndarray:
    """Lower factor L with ``L Lᵀ = Δ``, computed on the correlation matrix (Δ's diagonal spans decades at m = 6)."""
    s = np.sqrt(np.diagonal(delta))
    corr = delta / np.outer(s, s)
    try:
        return s[:, None] * np.linalg.cholesky(corr)
    except np.linalg.LinAlgError:  # numerically semidefinite: clip the spectrum at 0
        w, v = np.linalg.eigh(corr)
        return s[:, None] * (v * np.sqrt(np.clip(w, 0.0, None)))


def initial_error(kb: KalmanBucy, rng: np.random.Generator) -> np.ndarray:
    """The filters' common start error ``e(0) = Z(0) − X(0) = −e₀``, ``e₀ = L ξ ~ N(0, Δ)``, ξ ~ N(0, I_m) (SPEC §4)."""
    return -(_cholesky(np.asarray(kb.delta)) @ rng.standard_normal(len(kb.s)))


def _start(model: Model, kb: KalmanBucy, rng: np.random.Generator, start: str) -> tuple[np.ndarray, np.ndarray]:
    """``(X(0), e(0))`` drawn in this order from ``rng`` (the noise of the steps follows)."""
    x = initial_state(model, rng)
    e = initial_error(kb, rng) if start == "stationary" else np.zeros(model.m)
    return x, e


def _check_start(start) -> str:
    if not isinstance(start, str) or start not in STARTS:
        raise ValueError(f"start must be one of {list(STARTS)}, got {short(start)}")
    return start


def _pack(model: Model, filters: Sequence[FilterSpec], scenario: bool = False):
    """Kernel arguments of ``filters``: ``(damp, coef, kind, table, ad)`` (see :func:`isl_core.kernels.advance`).

    ``ad`` is the adaptive filters' fresh state (v = σ̂² = σ_init²); ``table`` is padded with its last row to
    the longest table (the same value held beyond the end) and is a 2-row dummy when no filter is adaptive.
    A variational-Bayes or robust filter is refused unless ``scenario`` (the scenario kernel's caller).
    """
    nf = len(filters)
    for f in filters:
        if (f.variational is not None or f.huber is not None or f.imm is not None) and not scenario:
            raise ValueError(f"the filter {f.label!r} runs in scenario runs only "
                             "(isl_core.scenario_run.simulate_scenario)")
    damp = np.array([f.damp for f in filters], dtype=np.float64)
    coef = np.array([f.coef for f in filters], dtype=np.float64).reshape(nf, model.m)
    kind = np.array([f.kind for f in filters], dtype=np.int8)
    nt = max([2] + [len(f.adaptive.log_gain) for f in filters if f.adaptive is not None])
    table = np.zeros((nf, nt, model.m))
    ad = np.zeros((nf, AD_WIDTH))
    for f, spec in enumerate(filters):
        gt = spec.adaptive
        if gt is None:
            continue
        table[f, :len(gt.log_gain)] = gt.log_gain
        table[f, len(gt.log_gain):] = gt.log_gain[-1]
        ad[f, AD_LOG_SIGMA0], ad[f, AD_INV_STEP], ad[f, AD_INV_MEMORY] = gt.log_sigma0, 1.0 / gt.step, 1.0 / gt.memory
        ad[f, AD_VAR], ad[f, AD_SIGMA] = gt.sigma_init**2, gt.sigma_init
    return damp, coef, kind, table, ad


def _loop(model, kb, filters, h, n, seed, *, start, burn, batches, X_out, E_out, S_out, store, progress=None,
          on_block=None, chunk=None):
    """Run the kernel over ``n`` steps chunk by chunk.

    ``store``: the trajectories are written to ``X_out`` (n+1, m), ``E_out`` (nf, n+1, m), ``S_out`` (na, n+1);
    or, with ``on_block``, each chunk is written to those buffers (chunk+1 rows) and handed over as
    ``on_block(X, E, S)`` — rows of the samples it added (the first call also gets sample 0) — so that no array
    of n rows ever exists. Returns squared-error sums (batches, nf, m), the adaptive filters' σ̂ sums
    (batches, na) and their final σ̂ (na,). ``progress(fraction)`` is called after every chunk; an exception it
    raises (e.g. to cancel) propagates.
    """
    rng = np.random.default_rng(seed)
    x, e0 = _start(model, kb, rng, start)
    e = np.tile(e0, (len(filters), 1))
    damp, coef, kind, table, ad = _pack(model, filters)
    adaptive = kind == KIND_ADAPTIVE
    if store:
        X_out[0] = x
        E_out[:, 0] = e
        S_out[:, 0] = ad[adaptive, AD_SIGMA]
        if on_block is not None:
            on_block(X_out[:1], E_out[:, :1], S_out[:, :1])
    sq = np.zeros((batches, len(filters), model.m))
    sig_sum = np.zeros((batches, int(adaptive.sum())))
    batch_len = (n - burn) // batches  # the remainder goes to the last batch
    chunk = chunk or CHUNK
    k = 0
    while k < n:
        todo = min(chunk, n - k)
        out0 = k if on_block is not None else 0
        done = advance(x, e, rng, todo, h, model.alpha, model.beta, model.sigma, damp, coef, kind, table, ad,
                       k, burn, batch_len, sq, sig_sum, X_out, E_out, S_out, store, out0)
        if done < todo:
            raise _divergence(model, filters, x if store else x[-1:], e, k + done, n, h)
        if on_block is not None:
            on_block(X_out[1:done + 1], E_out[:, 1:done + 1], S_out[:, 1:done + 1])
        k += done
        if progress is not None:
            progress(k / n)
    return sq, sig_sum, ad[adaptive, AD_SIGMA]


def _divergence(model: Model, filters, x, e, k: int, n: int, h: float) -> DivergenceError:
    """The error for a run that left the finite numbers at step ``k``: who diverged, when, and why."""
    bad = [f"filter {f.label}" for f, row in zip(filters, e) if not np.all(np.isfinite(row))]
    if not np.all(np.isfinite(x)):
        bad.insert(0, "the simulated truth")
    hint = "a smaller step h or a different nu keeps it finite"
    if h * model.alpha >= 2.0:
        hint = f"h·alpha = {h * model.alpha:.3g} >= 2 makes the Euler scheme unstable (B.47); use a smaller h"
    return DivergenceError(
        f"{' and '.join(bad) or 'the run'} diverged at t = {k * h:.4g} (step {k:,} of {n:,}, h = {h:.3g}); {hint}"
    )


def _check_progress(progress) -> None:
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be a callable or None, got {short(progress)}")


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
    progress: Callable[[float], None] | None = None,
) -> Run:
    """Simulate truth, the optimal Kalman–Bucy filter and the ISL filter with tuning ``nu`` on one grid.

    Length: ``T`` (absolute) if given, else ``horizon`` in units of 1/r_min (A, Fig. 3: 10), lengthened by
    ``stretch = r_min / settling_rate`` when the ISL filter settles slower than the optimal one (module
    docstring). ``h`` by :func:`step_size` over every filter simulated and ``step_filters`` — filters that are not
    simulated but must not change the grid when they are (e.g. those a view can show on demand). ``seed`` (int ≥ 0)
    fixes the noise: the same seed gives the same run, bit for bit. ``extra`` filters ride on the same noise.
    ``start``: :data:`STARTS`. ``every``: keep the trajectories at every ``every``-th step only (memory ÷ every;
    the RMSE still counts every step). ``progress(fraction)`` is called between kernel chunks; raising from it
    cancels. Raises ``ValueError`` for bad input or too many steps, :class:`DivergenceError` for a blown-up filter.
    """
    plan = run_plan(model, nu, horizon=horizon, T=T, h=h, extra=extra, step_filters=step_filters)
    seed = check_int("seed", seed, lo=0)
    every = check_int("every", every, lo=1)
    start = _check_start(start)
    _check_progress(progress)
    kb = kalman_bucy(model)
    filters = [optimal_kbf(model, kb), *check_filters(model, nu, extra)]
    T, h, n, stretch = plan.T, plan.h, plan.N, plan.stretch
    na = sum(spec.kind == KIND_ADAPTIVE for spec in filters)
    if every == 1:
        X, E, S = np.empty((n + 1, model.m)), np.empty((len(filters), n + 1, model.m)), np.empty((na, n + 1))
        sq, _, _ = _loop(model, kb, filters, h, n, seed, start=start, burn=0, batches=1, X_out=X, E_out=E, S_out=S,
                         store=True, progress=progress)
        kept = np.arange(n + 1)
    else:
        keep = _Stride(every, n, model.m, len(filters), na)
        rows = min(CHUNK, n) + 1
        sq, _, _ = _loop(model, kb, filters, h, n, seed, start=start, burn=0, batches=1, X_out=np.empty((rows, model.m)),
                         E_out=np.empty((len(filters), rows, model.m)), S_out=np.empty((na, rows)), store=True,
                         progress=progress, on_block=keep)
        X, E, S, kept = keep.X, keep.E, keep.S, keep.index
    s = _freeze(kb.s.copy())
    X = _freeze(X)
    tracks = []
    sigma_hat = iter(S)
    for f, spec in enumerate(filters):
        rmse = np.sqrt(sq[0, f] / n)  # (A.30)
        sig = _freeze(next(sigma_hat)) if spec.kind == KIND_ADAPTIVE else None
        tracks.append(Track(spec.name, spec.label, _freeze(E[f]), _freeze(rmse), _freeze(rmse / s), sig, X))
    t = kept.astype(np.float64)
    t *= h
    t = _freeze(t)
    return Run(model, float(nu), seed, t, X, tuple(tracks), s, kb.r_min, h, T, stretch, start, every)


class _Stride:
    """Keeps the samples k = 0, every, 2·every, … of the chunks :func:`_loop` hands over."""

    def __init__(self, every: int, n: int, m: int, nf: int, na: int) -> None:
        self.every, self.seen = every, 0
        self.index = np.arange(0, n + 1, every)
        self.X, self.E, self.S = np.empty((len(self.index), m)), np.empty((nf, len(self.index), m)), np.empty(
            (na, len(self.index)))

    def __call__(self, X: np.ndarray, E: np.ndarray, S: np.ndarray) -> None:
        k0, k1 = self.seen, self.seen + len(X)
        rows = np.arange(-(-k0 // self.every) * self.every, k1, self.every)  # kept samples in [k0, k1)
        at = rows // self.every
        self.X[at], self.E[:, at], self.S[:, at] = X[rows - k0], E[:, rows - k0], S[:, rows - k0]
        self.seen = k1
