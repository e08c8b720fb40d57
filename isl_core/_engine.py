"""The simulation engine's shared internals: one definition each, used by the simulation and scenario modules.

Private (its one public name, :class:`DivergenceError`, is re-exported by :mod:`isl_core`): how a run starts (the
truth at X(0), every filter's common start error e(0) = −e₀, :ref:`start`), how filters are packed for the compiled
kernel (:func:`pack`), the chunked loop over the kernel with progress and cancellation (:func:`run_chunks`), what a
run with tracks answers (:class:`Tracked`) and read-only result arrays (:func:`freeze`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Generic, Protocol, TypeVar, cast

import numpy as np
import numpy.typing as npt

from .filters.base import KIND_ADAPTIVE, FilterSpec
from .kernels.bundles import Batches, FilterBank, Grid, Trajectory
from .kernels.common import AD_INV_MEMORY, AD_INV_STEP, AD_LOG_SIGMA0, AD_SIGMA, AD_VAR, AD_WIDTH
from .kernels.euler import advance
from .model import Model
from .riccati import KalmanBucy
from .validate import short

__all__ = [
    "CHUNK",
    "STARTS",
    "DivergenceError",
    "Tracked",
    "check_progress",
    "check_start",
    "draw_noise",
    "draw_start",
    "freeze",
    "initial_error",
    "initial_state",
    "pack",
    "run_chunks",
]

CHUNK = 1 << 17  #: steps per kernel call (progress reports and cancellation happen between calls)
STARTS = ("stationary", "truth")  #: how the filters start (module docstring)


class DivergenceError(ArithmeticError):
    """A filter (or the simulated truth) left the finite numbers; the message says which, when, and a likely fix."""


def freeze(a: npt.ArrayLike, dtype: npt.DTypeLike | None = None) -> np.ndarray:
    """``a`` as a read-only array (``dtype`` if given; no copy when it already is one): the arrays of a result."""
    arr = np.asarray(a) if dtype is None else np.asarray(a, dtype=dtype)
    arr.flags.writeable = False
    return arr


class _Track(Protocol):
    """What :class:`Tracked` reads of a track: its filter's name and ratios."""

    @property
    def name(self) -> str: ...

    @property
    def ratio(self) -> np.ndarray: ...


_T = TypeVar("_T", bound=_Track)


class Tracked(Generic[_T]):
    """What a run with ``tracks`` (Kalman–Bucy, ISL, extras), ``T`` and ``r_min`` answers, full or decimated
    (:class:`Run`, :class:`isl_core.runview.RunView`)."""

    T: float
    r_min: float
    tracks: tuple[_T, ...]

    @property
    def horizon(self) -> float:
        """T in units of 1/r_min (A.24)."""
        return self.T * self.r_min

    def track(self, name: str) -> _T:
        for tr in self.tracks:
            if tr.name == name:
                return tr
        raise KeyError(f"no filter named {name!r} in this run; have {[tr.name for tr in self.tracks]}")

    ratio_hat = property(lambda self: self.tracks[0].ratio, doc="ŝ_i/s_i of the optimal filter (≈ 1 on long runs)")
    ratio_check = property(lambda self: self.tracks[1].ratio, doc="š_i/s_i of the ISL filter")


def draw_noise(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` rows of (v_k, ε_k) ~ N(0, 1): column 0 drives the signal (B.33), column 1 the observation (B.34).

    The compiled kernel draws the same stream from the same generator, one number at a time.
    """
    return rng.standard_normal((n, 2))


def initial_state(model: Model, rng: np.random.Generator) -> np.ndarray:
    """Truth at t = 0: zero except X_m(0) ~ N(0, β²/(2α)) when α > 0 (:ref:`start`)."""
    x = np.zeros(model.m)
    if model.alpha > 0.0:
        x[-1] = math.sqrt(model.stationary_var) * rng.standard_normal()
    return x


def _cholesky(delta: np.ndarray) -> np.ndarray:
    """Lower factor L with ``L Lᵀ = Δ``, computed on the correlation matrix (Δ's diagonal spans decades at m = 6)."""
    s = np.sqrt(np.diagonal(delta))
    corr = delta / np.outer(s, s)
    try:
        return cast("np.ndarray", s[:, None] * np.linalg.cholesky(corr))
    except np.linalg.LinAlgError:  # numerically semidefinite: clip the spectrum at 0
        w, v = np.linalg.eigh(corr)
        return cast("np.ndarray", s[:, None] * (v * np.sqrt(np.clip(w, 0.0, None))))


def initial_error(kb: KalmanBucy, rng: np.random.Generator) -> np.ndarray:
    """The filters' common start error ``e(0) = Z(0) − X(0) = −e₀``, ``e₀ = L ξ ~ N(0, Δ)``, ξ ~ N(0, I_m)
    (:ref:`start`)."""
    return -(_cholesky(np.asarray(kb.delta)) @ rng.standard_normal(len(kb.s)))


def draw_start(model: Model, kb: KalmanBucy, rng: np.random.Generator, start: str) -> tuple[np.ndarray, np.ndarray]:
    """``(X(0), e(0))`` drawn in this order from ``rng`` (the noise of the steps follows)."""
    x = initial_state(model, rng)
    e = initial_error(kb, rng) if start == "stationary" else np.zeros(model.m)
    return x, e


def check_start(start: object) -> str:
    if not isinstance(start, str) or start not in STARTS:
        raise ValueError(f"start must be one of {list(STARTS)}, got {short(start)}")
    return start


def check_progress(progress: object) -> None:
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be a callable or None, got {short(progress)}")


def pack(model: Model, filters: Sequence[FilterSpec], scenario: bool = False) -> FilterBank:
    """``filters`` packed for a kernel (:class:`isl_core.kernels.bundles.FilterBank`).

    ``ad`` is the adaptive filters' fresh state (v = σ̂² = σ_init²); ``table`` is padded with its last row to
    the longest table (the same value held beyond the end) and is a 2-row dummy when no filter is adaptive.
    A variational-Bayes or robust filter is refused unless ``scenario`` (the scenario kernel's caller).
    """
    nf = len(filters)
    for f in filters:
        if (f.variational is not None or f.huber is not None or f.imm is not None) and not scenario:
            raise ValueError(
                f"the filter {f.label!r} runs in scenario runs only (isl_core.scenario.run.simulate_scenario)"
            )
    damp = np.array([f.damp for f in filters], dtype=np.float64)
    coef = np.array([f.coef for f in filters], dtype=np.float64).reshape(nf, model.m)
    kind = np.array([f.kind for f in filters], dtype=np.int8)
    nt = max([2] + [len(f.adaptive.log_gain) for f in filters if f.adaptive is not None])
    table = np.zeros((nf, nt, model.m))
    ad = np.zeros((nf, AD_WIDTH))
    for i, spec in enumerate(filters):
        gt = spec.adaptive
        if gt is None:
            continue
        table[i, : len(gt.log_gain)] = gt.log_gain
        table[i, len(gt.log_gain) :] = gt.log_gain[-1]
        ad[i, AD_LOG_SIGMA0], ad[i, AD_INV_STEP], ad[i, AD_INV_MEMORY] = gt.log_sigma0, 1.0 / gt.step, 1.0 / gt.memory
        ad[i, AD_VAR], ad[i, AD_SIGMA] = gt.sigma_init**2, gt.sigma_init
    return FilterBank(damp, coef, kind, table, ad)


def run_chunks(
    model: Model,
    kb: KalmanBucy,
    filters: Sequence[FilterSpec],
    h: float,
    n: int,
    seed: int,
    *,
    start: str,
    burn: int,
    batches: int,
    out: Trajectory,
    progress: Callable[[float], None] | None = None,
    on_block: Callable[[np.ndarray, np.ndarray, np.ndarray], None] | None = None,
    chunk: int | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the constant-σ kernel (:func:`isl_core.kernels.euler.advance`) over ``n`` steps, chunk by chunk.

    ``out`` (:class:`isl_core.kernels.bundles.Trajectory`): if ``store``, the trajectories are written to ``X``
    (n+1, m), ``E`` (nf, n+1, m), ``S`` (na, n+1); or, with ``on_block``, each chunk is written to those buffers
    (chunk+1 rows) and handed over as ``on_block(X, E, S)`` — rows of the samples it added (the first call also gets
    sample 0) — so that no array of n rows ever exists. Returns squared-error sums (batches, nf, m) after ``burn``
    steps, the adaptive filters' σ̂ sums (batches, na) and their final σ̂ (na,). ``progress(fraction)`` is called
    after every chunk; an exception it raises (e.g. to cancel) propagates.
    """
    rng = np.random.default_rng(seed)
    x, e0 = draw_start(model, kb, rng, start)
    e = np.tile(e0, (len(filters), 1))
    bank = pack(model, filters)
    adaptive = bank.kind == KIND_ADAPTIVE
    if out.store:
        out.X[0], out.E[:, 0], out.S[:, 0] = x, e, bank.ad[adaptive, AD_SIGMA]
        if on_block is not None:
            on_block(out.X[:1], out.E[:, :1], out.S[:, :1])
    sums = Batches(
        burn,
        (n - burn) // batches,  # the remainder goes to the last batch
        np.zeros((batches, len(filters), model.m)),
        np.zeros((batches, int(adaptive.sum()))),
    )
    grid = Grid(float(h), model.alpha, model.beta)
    chunk = chunk or CHUNK
    k = 0
    while k < n:
        todo = min(chunk, n - k)
        if on_block is not None:
            out = out._replace(first=k)
        done = advance(x, e, rng, todo, k, grid, model.sigma, bank, sums, out)
        if done < todo:
            raise divergence(model, filters, x if out.store else x[-1:], e, k + done, n, h)
        if on_block is not None:
            on_block(out.X[1 : done + 1], out.E[:, 1 : done + 1], out.S[:, 1 : done + 1])
        k += done
        if progress is not None:
            progress(k / n)
    return sums.sq, sums.sig_sum, bank.ad[adaptive, AD_SIGMA]


def divergence(
    model: Model, filters: Sequence[FilterSpec], x: np.ndarray, e: np.ndarray, k: int, n: int, h: float
) -> DivergenceError:
    """The error for a run that left the finite numbers at step ``k``: who diverged, when, and why."""
    bad = [f"filter {f.label}" for f, row in zip(filters, e, strict=False) if not np.all(np.isfinite(row))]
    if not np.all(np.isfinite(x)):
        bad.insert(0, "the simulated truth")
    hint = "a smaller step h or a different nu keeps it finite"
    if h * model.alpha >= 2.0:
        hint = f"h·alpha = {h * model.alpha:.3g} >= 2 makes the Euler scheme unstable (B.47); use a smaller h"
    return DivergenceError(
        f"{' and '.join(bad) or 'the run'} diverged at t = {k * h:.4g} (step {k:,} of {n:,}, h = {h:.3g}); {hint}"
    )
