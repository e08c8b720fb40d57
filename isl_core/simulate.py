"""Simulation of the truth and the filters on one Euler grid (B.30–B.34, A.18, A.29–A.30, SPEC §4, §8).

The truth is simulated by Euler–Maruyama **on the filters' grid** (B.33–B.34): an exact-in-continuous-time
truth would make ΔY/h the step average of X_1 and bias every Euler filter by ≈ (h/2)·X_2 (SPEC §4). The filters
are integrated in error coordinates e = Z − X (SPEC §8, :mod:`isl_core.kernels`): their errors keep every digit
whatever the size of the signal; the estimates are rebuilt as ``Z = X + e`` for display only.

Step size (B.47): every closed-loop rate must satisfy ``h·|λ| ≪ 1``. We take the fastest rate in play,
``max(|λ(A − KC)|, α, |λ(Λ_f)|, r_min)`` with Λ_f the linearized matrix of each filter (B.46), and set
``h = H_RATE / rate`` (H_RATE = 0.02). The grid itself biases every RMSE by O(h·rate); for the optimal filter the
bias is exact — the stationary covariance of its Euler error recursion, a discrete Lyapunov equation — and grows
with m (3 % at m = 6 with H_RATE alone), so h is shrunk further until that bias is at most EULER_BIAS = 1 %.
Then ``N = ⌈T/h⌉`` and h is shrunk to ``T/N`` so that t_N = T. N is capped (MAX_STORED_STEPS with trajectories,
MAX_STEPS without): beyond, a ``ValueError`` says so.

Length: the horizon is counted in units of 1/r_min (A.24), the settling time of the optimal filter. A filter
whose slowest closed-loop mode (B.46) is slower needs longer to forget its start and to average out:
:func:`settling_rate` is the slowest rate among the filters in play, and ``T = horizon / settling_rate``
("lengthened" by ``r_min / settling_rate``) when another filter is more than SETTLE_TOL = 10 % slower than the
optimal one (a mode 10 % slower has still decayed by e⁻⁹ where the optimal one has by e⁻¹⁰).

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

from .validate import check_int, check_real, short
from .filters import KIND_ADAPTIVE, FilterSpec, isl_filter, linearized_matrix, optimal_kbf
from .kernels import AD_INV_STEP, AD_INV_WINDOW, AD_LOG_SIGMA0, AD_SIGMA, AD_VAR, AD_WIDTH, advance
from .model import Model
from .riccati import KalmanBucy, kalman_bucy
from .theory import lyapunov

__all__ = [
    "EULER_BIAS",
    "H_RATE",
    "MAX_STEPS",
    "MAX_STORED_STEPS",
    "SETTLE_TOL",
    "STARTS",
    "DivergenceError",
    "RmseResult",
    "Run",
    "RunPlan",
    "Track",
    "draw_noise",
    "euler_bias",
    "initial_error",
    "initial_state",
    "run_plan",
    "settling_rate",
    "simulate",
    "simulate_rmse",
    "step_size",
]

H_RATE = 0.02  #: h × (fastest rate): the SPEC's margin
EULER_BIAS = 0.01  #: largest relative bias the Euler grid may add to the optimal filter's RMSE (exact, see below)
MAX_STORED_STEPS = 4_000_000  #: cap on N when trajectories are kept (memory 8·(m·(filters + 1) + 1)·N bytes)
MAX_STEPS = 200_000_000  #: cap on N when only squared errors are accumulated
CHUNK = 1 << 17  #: steps per kernel call (progress reports and cancellation happen between calls)
STARTS = ("stationary", "truth")  #: how the filters start (module docstring)
SETTLE_TOL = 1.1  #: a filter slower than the optimal one by more than this factor lengthens the run


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


def euler_bias(model: Model, kb: KalmanBucy, h: float) -> float:
    """Relative bias ``max_i √(P_ii/Δ_ii) − 1`` of the optimal filter's RMSE on the Euler grid of step ``h``.

    Its error obeys ``e_{k+1} = (I + h(A − KC))e_k − βE√h v_k + Kσ√h ε_k`` (B.30, B.33–B.34), whose stationary
    covariance P solves ``P = F P Fᵀ + h(β²EEᵀ + σ²KKᵀ)``, F = I + h(A − KC) — exact, not an estimate.
    """
    K = np.asarray(kb.K)
    M = model.A - np.outer(K, model.C[0])
    Q = model.beta**2 * (model.E @ model.E.T) + model.sigma**2 * np.outer(K, K)
    P = lyapunov(M, Q, h)
    return float(np.max(np.abs(np.sqrt(np.diagonal(P) / np.diagonal(kb.delta)) - 1.0)))


def step_size(model: Model, kb: KalmanBucy, filters: Sequence[FilterSpec]) -> float:
    """``h = H_RATE / max(|λ(A − KC)|, α, |λ(Λ_f)|, r_min)`` (B.47 with a margin, SPEC §4), shrunk until the grid
    biases the optimal filter's RMSE by at most :data:`EULER_BIAS` (:func:`euler_bias`)."""
    rate = max(float(np.max(np.abs(kb.eig))), model.alpha, kb.r_min)
    for spec in filters:
        rate = max(rate, float(np.max(np.abs(np.linalg.eigvals(linearized_matrix(model, spec))))))
    h = H_RATE / rate
    for _ in range(8):  # the bias is ∝ h for small h: one rescaling nearly always suffices
        bias = euler_bias(model, kb, h)
        if bias <= EULER_BIAS:
            break
        h *= 0.98 * EULER_BIAS / bias
    return h


def settling_rate(model: Model, kb: KalmanBucy, filters: Sequence[FilterSpec]) -> float:
    """Slowest closed-loop rate among the optimal filter and ``filters``: ``min(r_min, min_f −Re λ(Λ_f))`` (B.46).

    Λ_f is the statistically linearized matrix of filter f (:func:`isl_core.linearized_matrix`). An adaptive filter
    settles like the optimal one (its gain follows K(σ̂) → K(σ)); a filter whose Λ_f is not stable has no stationary
    regime to wait for and is left out (its ratio is what the run shows). A filter at most :data:`SETTLE_TOL` times
    slower than the optimal one counts as settling with it (the result is then exactly r_min).
    """
    rate = kb.r_min
    for spec in filters:
        if spec.adaptive is not None:
            continue
        slow = float(np.min(-np.linalg.eigvals(linearized_matrix(model, spec)).real))
        if slow > 0.0 and slow * SETTLE_TOL < kb.r_min:
            rate = min(rate, slow)
    return rate


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


def _grid(model: Model, kb: KalmanBucy, filters, T, h, cap: int, *, default_T: float | None = None):
    """``(T, h, N)`` with ``N·h = T``: ``T`` (default ``default_T``, else 10/r_min), ``h`` by :func:`step_size`."""
    if T is None:
        T = 10.0 / kb.r_min if default_T is None else default_T
    else:
        T = check_real("T", T, lo=0.0, lo_open=True)
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


def _check_filters(model: Model, nu, extra) -> list[FilterSpec]:
    if not isinstance(model, Model):
        raise ValueError(f"model must be an isl_core.Model, got {type(model).__name__}")
    nu = check_real("nu", nu, lo=0.0, lo_open=True)
    extra = _check_specs("extra", model, extra, allow_empty=True)
    return [isl_filter(model, nu), *extra]


def _check_specs(name: str, model: Model, specs, *, allow_empty: bool) -> list[FilterSpec]:
    """``specs`` as a list of :class:`FilterSpec` of the model's size, or a ``ValueError`` naming ``name``."""
    what = f"{name} must be a {'' if allow_empty else 'non-empty '}sequence of FilterSpec of size m = {model.m}"
    if not isinstance(specs, list | tuple | range):
        raise ValueError(f"{what}, got {short(specs)}")
    specs = list(specs)
    if not (specs or allow_empty):
        raise ValueError(f"{what}, got an empty sequence")
    for spec in specs:
        if not isinstance(spec, FilterSpec) or np.shape(spec.coef) != (model.m,):
            raise ValueError(f"{what}, got {short(spec)}")
        table = None if spec.adaptive is None else np.shape(getattr(spec.adaptive, "log_gain", None))
        if table is not None and not (len(table) == 2 and table[0] >= 2 and table[1] == model.m):
            raise ValueError(f"{what} (an adaptive gain table of shape (n >= 2, m)), got {short(spec)}")
    return specs


def _check_progress(progress) -> None:
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be a callable or None, got {short(progress)}")


@dataclass(frozen=True)
class RunPlan:
    """The grid of a :func:`simulate` call, known before anything is allocated: ``T = N·h``, ``stretch`` (≥ 1)."""

    T: float
    h: float
    N: int
    stretch: float
    r_min: float

    @property
    def horizon(self) -> float:
        """T in units of 1/r_min (A.24)."""
        return self.T * self.r_min


def run_plan(
    model: Model,
    nu: float,
    *,
    horizon: float = 10.0,
    T: float | None = None,
    h: float | None = None,
    extra: Sequence[FilterSpec] = (),
    step_filters: Sequence[FilterSpec] = (),
    cap: int = MAX_STORED_STEPS,
) -> RunPlan:
    """The grid :func:`simulate` would use for these arguments (same rules, same checks, nothing simulated).

    ``cap``: the largest N allowed (a ``ValueError`` past it names T and h).
    """
    filters = _check_filters(model, nu, extra)
    grid_only = _check_specs("step_filters", model, step_filters, allow_empty=True)
    horizon = check_real("horizon", horizon, lo=0.0, lo_open=True)
    kb = kalman_bucy(model)
    filters.insert(0, optimal_kbf(model, kb))
    stretch = 1.0 if T is not None else kb.r_min / settling_rate(model, kb, filters[1:2])
    T, h, n = _grid(model, kb, [*filters, *grid_only], T, h, cap, default_T=horizon * stretch / kb.r_min)
    return RunPlan(T, h, n, stretch, kb.r_min)


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
    filters = [optimal_kbf(model, kb), *_check_filters(model, nu, extra)]
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


@dataclass(frozen=True)
class RmseResult:
    """Squared-error sums of a long run without stored trajectories.

    ``sq`` (batches, nf, m) holds per-batch sums of ``(Z_f,i − X_i)²`` over ``batch_len`` steps each
    (the last batch takes the remainder: ``counts``); ``s`` is the optimal RMSE √diag Δ (theory).
    ``burn`` (time) was left out before the first batch. ``sigma_hat`` (batches, nf): per-batch mean of an
    adaptive filter's σ̂, ``sigma_hat_final`` (nf,) its value at the end; nan for the other filters.
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
    burn: float = 0.0

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
    start: str = "stationary",
    step_filters: Sequence[FilterSpec] = (),
    progress: Callable[[float], None] | None = None,
) -> RmseResult:
    """Long run of ``filters`` on one truth (common random numbers), accumulating squared errors only.

    The first ``burn`` time units are left out of the averages; the rest is cut into ``batches``.
    ``step_filters``: more filters that count for the step size only (as in :func:`simulate`).
    ``progress(fraction)`` is called between kernel chunks; raising from it cancels the run.
    """
    if not isinstance(model, Model):
        raise ValueError(f"model must be an isl_core.Model, got {type(model).__name__}")
    filters = _check_specs("filters", model, filters, allow_empty=False)
    grid_only = _check_specs("step_filters", model, step_filters, allow_empty=True)
    _check_progress(progress)
    seed = check_int("seed", seed, lo=0)
    batches = check_int("batches", batches, lo=1, hi=10_000)
    start = _check_start(start)
    kb = kalman_bucy(model)
    T, h, n = _grid(model, kb, [*filters, *grid_only], check_real("T", T, lo=0.0, lo_open=True), h, MAX_STEPS)
    burn_steps = min(int(check_real("burn", burn, lo=0.0, hi=T) / h), n - batches)
    if burn_steps < 0:
        raise ValueError(f"batches must be <= the number of steps {n}, got {batches}")
    dummy_x, dummy_e = np.empty((1, model.m)), np.empty((len(filters), 1, model.m))
    adaptive = np.array([f.kind == KIND_ADAPTIVE for f in filters])
    dummy_s = np.empty((int(adaptive.sum()), 1))
    sq, sig_sum, sig_final = _loop(model, kb, filters, h, n, seed, start=start, burn=burn_steps, batches=batches,
                                   X_out=dummy_x, E_out=dummy_e, S_out=dummy_s, store=False, progress=progress)
    counts = np.full(batches, float((n - burn_steps) // batches))
    counts[-1] = (n - burn_steps) - counts[0] * (batches - 1)
    sigma_hat = np.full((batches, len(filters)), np.nan)
    sigma_hat[:, adaptive] = sig_sum / counts[:, None]
    final = np.full(len(filters), np.nan)
    final[adaptive] = sig_final
    return RmseResult(tuple(f.name for f in filters), sq, counts, kb.s.copy(), kb.r_min, h, T, sigma_hat, final,
                      burn_steps * h)
