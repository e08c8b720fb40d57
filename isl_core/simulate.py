"""Simulation of the truth and the filters on one Euler grid (B.30–B.34, A.18, A.29–A.30).

The truth is simulated by Euler–Maruyama **on the filters' grid** (B.33–B.34): an exact-in-continuous-time
truth would make ΔY/h the step average of X_1 and bias every Euler filter by ≈ (h/2)·X_2 (SPEC §4).

Step size (B.47): every closed-loop rate must satisfy ``h·|λ| ≪ 1``. We take the fastest rate in play,
``max(|λ(A − KC)|, α, |λ(Λ_f)|, r_min)`` with Λ_f the linearized matrix of each filter (B.46), and set
``h = H_RATE / rate`` (H_RATE = 0.02, and at most T); then ``N = ⌈T/h⌉`` and h is shrunk to ``T/N`` so that
t_N = T. N is capped (MAX_STORED_STEPS with trajectories, MAX_STEPS without): beyond, a ``ValueError`` says so.

Empirical RMSE along one trajectory (A.30): ``š_i = √(mean_{k=1..N} (Z_i(t_k) − X_i(t_k))²)``.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ._validate import check_int, check_real
from .filters import KIND_ADAPTIVE, FilterSpec, isl_filter, linearized_matrix, optimal_kbf
from .kernels import AD_INV_STEP, AD_INV_WINDOW, AD_LOG_SIGMA0, AD_SIGMA, AD_VAR, AD_WIDTH, advance
from .model import Model
from .riccati import KalmanBucy, kalman_bucy

__all__ = [
    "H_RATE",
    "MAX_STEPS",
    "MAX_STORED_STEPS",
    "DivergenceError",
    "RmseResult",
    "Run",
    "Track",
    "draw_noise",
    "initial_state",
    "simulate",
    "simulate_rmse",
    "step_size",
]

H_RATE = 0.02  #: h × (fastest rate): the SPEC's margin
MAX_STORED_STEPS = 4_000_000  #: cap on N when trajectories are kept (memory 8·(m·(filters + 1) + 1)·N bytes)
MAX_STEPS = 200_000_000  #: cap on N when only squared errors are accumulated
CHUNK = 1 << 17  #: steps per kernel call (progress reports and cancellation happen between calls)


class DivergenceError(ArithmeticError):
    """A filter (or the simulated truth) left the finite numbers; the message says which, when, and a likely fix."""


def _freeze(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class Track:
    """One filter's estimate along a run and its empirical RMSE (A.30) and ratio ``š_i/s_i``.

    ``sigma_hat`` (N+1,): an adaptive filter's online estimate σ̂(t_k) (σ̂(0) its initial value); None otherwise.
    """

    name: str
    label: str
    estimate: np.ndarray
    rmse: np.ndarray
    ratio: np.ndarray
    sigma_hat: np.ndarray | None = None


@dataclass(frozen=True)
class Run:
    """One simulated trajectory with the optimal and the ISL filter (and any extra filters).

    ``t`` (N+1,), ``X`` truth (N+1, m), ``tracks`` in order: Kalman–Bucy, ISL, extras.
    ``s = √diag Δ`` (theory, A.29–A.30), ``r_min`` (A.24), ``h`` step, ``T = t_N``.
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

    @property
    def N(self) -> int:
        return len(self.t) - 1

    def track(self, name: str) -> Track:
        for tr in self.tracks:
            if tr.name == name:
                return tr
        raise KeyError(f"no filter named {name!r} in this run; have {[tr.name for tr in self.tracks]}")

    X_hat = property(lambda self: self.tracks[0].estimate, doc="Kalman–Bucy estimate X̂ (N+1, m)")
    X_check = property(lambda self: self.tracks[1].estimate, doc="ISL estimate X̌ (N+1, m)")
    s_hat = property(lambda self: self.tracks[0].rmse, doc="empirical RMSE ŝ_i of X̂ (A.30)")
    s_check = property(lambda self: self.tracks[1].rmse, doc="empirical RMSE š_i of X̌ (A.30)")
    ratio_hat = property(lambda self: self.tracks[0].ratio, doc="ŝ_i/s_i (≈ 1 on long runs)")
    ratio_check = property(lambda self: self.tracks[1].ratio, doc="š_i/s_i")


def step_size(model: Model, kb: KalmanBucy, filters: Sequence[FilterSpec]) -> float:
    """``h = H_RATE / max(|λ(A − KC)|, α, |λ(Λ_f)|, r_min)`` (B.47 with a margin, SPEC §4)."""
    rate = max(float(np.max(np.abs(kb.eig))), model.alpha, kb.r_min)
    for spec in filters:
        rate = max(rate, float(np.max(np.abs(np.linalg.eigvals(linearized_matrix(model, spec))))))
    return H_RATE / rate


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


def _grid(model: Model, kb: KalmanBucy, filters, T, h, cap: int) -> tuple[float, float, int]:
    """``(T, h, N)`` with ``N·h = T``: defaults ``T = 10/r_min`` and ``h`` by :func:`step_size` (at most T)."""
    T = 10.0 / kb.r_min if T is None else check_real("T", T, lo=0.0, lo_open=True)
    if h is None:
        h = min(step_size(model, kb, filters), T)
    else:
        h = check_real("h", h, lo=0.0, lo_open=True)
        if h > T:
            raise ValueError(f"h must be a finite number > 0 and <= T = {T:g}, got {h:g}")
    steps = T / h  # may overflow to inf for extreme T/h: compared before any integer conversion
    if not steps <= cap:
        raise ValueError(
            f"T/h = {T:g}/{h:.4g} needs {steps:,.0f} steps, over the limit of {cap:,}; shorten T or enlarge h"
        )
    n = max(1, math.ceil(steps - 1e-9))
    return T, T / n, n


def _pack(model: Model, filters: Sequence[FilterSpec]):
    """Kernel arguments of ``filters``: ``(damp, coef, kind, table, ad)`` (see :func:`isl_core.kernels.advance`).

    ``ad`` is the adaptive filters' fresh state (v = σ̂² = σ_init²); ``table`` is padded with its last row to
    the longest table (the same value held beyond the end) and is a 2-row dummy when no filter is adaptive.
    """
    nf = len(filters)
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
        ad[f, AD_LOG_SIGMA0], ad[f, AD_INV_STEP], ad[f, AD_INV_WINDOW] = gt.log_sigma0, 1.0 / gt.step, 1.0 / gt.window
        ad[f, AD_VAR], ad[f, AD_SIGMA] = gt.sigma_init**2, gt.sigma_init
    return damp, coef, kind, table, ad


def _loop(model, filters, h, n, seed, *, burn, batches, X_out, Z_out, S_out, store, progress=None):
    """Run the kernel over ``n`` steps chunk by chunk.

    Returns squared-error sums (batches, nf, m), the adaptive filters' σ̂ sums (batches, na) and their final σ̂
    (na,). ``progress(fraction)`` is called after every chunk; an exception it raises (e.g. to cancel) propagates.
    """
    rng = np.random.default_rng(seed)
    x = initial_state(model, rng)
    z = np.zeros((len(filters), model.m))
    damp, coef, kind, table, ad = _pack(model, filters)
    adaptive = kind == KIND_ADAPTIVE
    if store:
        X_out[0] = x
        S_out[:, 0] = ad[adaptive, AD_SIGMA]
    sq = np.zeros((batches, len(filters), model.m))
    sig_sum = np.zeros((batches, int(adaptive.sum())))
    batch_len = (n - burn) // batches  # the remainder goes to the last batch
    k = 0
    while k < n:
        todo = min(CHUNK, n - k)
        done = advance(x, z, rng, todo, h, model.alpha, model.beta, model.sigma, damp, coef, kind, table, ad,
                       k, burn, batch_len, sq, sig_sum, X_out, Z_out, S_out, store)
        if done < todo:
            raise _divergence(model, filters, x, z, k + done, n, h)
        k += done
        if progress is not None:
            progress(k / n)
    return sq, sig_sum, ad[adaptive, AD_SIGMA]


def _divergence(model: Model, filters, x, z, k: int, n: int, h: float) -> DivergenceError:
    """The error for a run that left the finite numbers at step ``k``: who diverged, when, and why."""
    bad = [f"filter {f.label}" for f, row in zip(filters, z) if not np.all(np.isfinite(row))]
    if not np.all(np.isfinite(x)):
        bad.insert(0, "the simulated truth")
    hint = "a smaller step h or a different nu keeps it finite"
    if h * model.alpha >= 2.0:
        hint = f"h·alpha = {h * model.alpha:.3g} >= 2 makes the Euler scheme unstable (B.47); use a smaller h"
    return DivergenceError(
        f"{' and '.join(bad) or 'the run'} diverged at t = {k * h:.4g} (step {k:,} of {n:,}, h = {h:.3g}); {hint}"
    )


def _check_filters(model: Model, nu, extra) -> list[FilterSpec]:
    if not isinstance(model, Model):
        raise ValueError(f"model must be an isl_core.Model, got {type(model).__name__}")
    nu = check_real("nu", nu, lo=0.0, lo_open=True)
    extra = _check_specs("extra", model, extra, allow_empty=True)
    return [isl_filter(model, nu), *extra]


def _check_specs(name: str, model: Model, specs, *, allow_empty: bool) -> list[FilterSpec]:
    """``specs`` as a list of :class:`FilterSpec` of the model's size, or a ``ValueError`` naming ``name``."""
    what = f"{name} must be a {'' if allow_empty else 'non-empty '}sequence of FilterSpec of size m = {model.m}"
    if isinstance(specs, (FilterSpec, str, bytes)) or not hasattr(specs, "__iter__"):
        raise ValueError(f"{what}, got {specs!r}")
    specs = list(specs)
    if not (specs or allow_empty):
        raise ValueError(f"{what}, got an empty sequence")
    for spec in specs:
        if not isinstance(spec, FilterSpec) or np.shape(spec.coef) != (model.m,):
            raise ValueError(f"{what}, got {spec!r}")
        table = None if spec.adaptive is None else np.shape(getattr(spec.adaptive, "log_gain", None))
        if table is not None and not (len(table) == 2 and table[0] >= 2 and table[1] == model.m):
            raise ValueError(f"{what} (an adaptive gain table of shape (n >= 2, m)), got {spec!r}")
    return specs


def simulate(
    model: Model,
    nu: float,
    *,
    T: float | None = None,
    h: float | None = None,
    seed: int = 0,
    extra: Sequence[FilterSpec] = (),
) -> Run:
    """Simulate truth, the optimal Kalman–Bucy filter and the ISL filter with tuning ``nu`` on one grid.

    Defaults: ``T = 10/r_min`` (A, Fig. 3) and ``h`` by :func:`step_size`. ``seed`` (int ≥ 0) fixes the
    noise: the same seed gives the same run, bit for bit. ``extra`` filters ride on the same noise.
    Raises ``ValueError`` for bad input or too many steps, :class:`DivergenceError` for a blown-up filter.
    """
    filters = _check_filters(model, nu, extra)
    seed = check_int("seed", seed, lo=0)
    kb = kalman_bucy(model)
    filters.insert(0, optimal_kbf(model, kb))
    T, h, n = _grid(model, kb, filters, T, h, MAX_STORED_STEPS)
    X = np.empty((n + 1, model.m))
    Z = np.empty((len(filters), n + 1, model.m))
    for f in range(len(filters)):
        Z[f, 0] = 0.0
    S = np.empty((sum(spec.kind == KIND_ADAPTIVE for spec in filters), n + 1))
    sq, _, _ = _loop(model, filters, h, n, seed, burn=0, batches=1, X_out=X, Z_out=Z, S_out=S, store=True)
    s = _freeze(kb.s.copy())
    tracks = []
    sigma_hat = iter(S)
    for f, spec in enumerate(filters):
        rmse = np.sqrt(sq[0, f] / n)  # (A.30)
        sig = _freeze(next(sigma_hat)) if spec.kind == KIND_ADAPTIVE else None
        tracks.append(Track(spec.name, spec.label, _freeze(Z[f]), _freeze(rmse), _freeze(rmse / s), sig))
    t = np.arange(n + 1, dtype=np.float64)
    t *= h
    t = _freeze(t)
    return Run(model, float(nu), seed, t, _freeze(X), tuple(tracks), s, kb.r_min, h, T)


@dataclass(frozen=True)
class RmseResult:
    """Squared-error sums of a long run without stored trajectories.

    ``sq`` (batches, nf, m) holds per-batch sums of ``(Z_f,i − X_i)²`` over ``batch_len`` steps each
    (the last batch takes the remainder: ``counts``); ``s`` is the optimal RMSE √diag Δ (theory).
    ``sigma_hat`` (batches, nf): per-batch mean of an adaptive filter's σ̂, ``sigma_hat_final`` (nf,) its
    value at the end; nan for the other filters.
    """

    names: tuple[str, ...]
    sq: np.ndarray
    counts: np.ndarray
    s: np.ndarray
    r_min: float
    h: float
    T: float
    sigma_hat: np.ndarray | None = None
    sigma_hat_final: np.ndarray | None = None

    def ratios(self) -> np.ndarray:
        """Whole-run ratios ``š_i/s_i`` (nf, m), (A.30)."""
        return np.sqrt(self.sq.sum(axis=0) / self.counts.sum()) / self.s

    def batch_ratios(self) -> np.ndarray:
        """Per-batch ratios (batches, nf, m), for batch-means confidence intervals."""
        return np.sqrt(self.sq / self.counts[:, None, None]) / self.s


def simulate_rmse(
    model: Model,
    filters: Sequence[FilterSpec],
    *,
    T: float,
    h: float | None = None,
    seed: int = 0,
    burn: float = 0.0,
    batches: int = 1,
    progress: Callable[[float], None] | None = None,
) -> RmseResult:
    """Long run of ``filters`` on one truth (common random numbers), accumulating squared errors only.

    The first ``burn`` time units are left out of the averages; the rest is cut into ``batches``.
    ``progress(fraction)`` is called between kernel chunks; raising from it cancels the run.
    """
    if not isinstance(model, Model):
        raise ValueError(f"model must be an isl_core.Model, got {type(model).__name__}")
    filters = _check_specs("filters", model, filters, allow_empty=False)
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be a callable or None, got {progress!r}")
    seed = check_int("seed", seed, lo=0)
    batches = check_int("batches", batches, lo=1, hi=10_000)
    kb = kalman_bucy(model)
    T, h, n = _grid(model, kb, filters, T, h, MAX_STEPS)
    burn_steps = min(int(check_real("burn", burn, lo=0.0, hi=T) / h), n - batches)
    if burn_steps < 0:
        raise ValueError(f"batches must be <= the number of steps {n}, got {batches}")
    dummy_x, dummy_z = np.empty((1, model.m)), np.empty((len(filters), 1, model.m))
    adaptive = np.array([f.kind == KIND_ADAPTIVE for f in filters])
    dummy_s = np.empty((int(adaptive.sum()), 1))
    sq, sig_sum, sig_final = _loop(model, filters, h, n, seed, burn=burn_steps, batches=batches, X_out=dummy_x,
                                   Z_out=dummy_z, S_out=dummy_s, store=False, progress=progress)
    counts = np.full(batches, float((n - burn_steps) // batches))
    counts[-1] = (n - burn_steps) - counts[0] * (batches - 1)
    sigma_hat = np.full((batches, len(filters)), np.nan)
    sigma_hat[:, adaptive] = sig_sum / counts[:, None]
    final = np.full(len(filters), np.nan)
    final[adaptive] = sig_final
    return RmseResult(tuple(f.name for f in filters), sq, counts, kb.s.copy(), kb.r_min, h, T, sigma_hat, final)
