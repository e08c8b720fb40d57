"""The compiled time loop: truth, observation and every filter's error in one pass (B.30, B.32–B.34, A.18,
:ref:`error-coordinates`).

One step k → k+1 on the grid t_k = k·h, with v_k, ε_k ~ N(0, 1) drawn from the caller's
``numpy.random.Generator`` inside the loop (numba reproduces NumPy's stream bit for bit: v_k, ε_k are the
rows of ``rng.standard_normal((n, 2))``). The filters are integrated in **error coordinates** e_f = Z_f − X
(:ref:`error-coordinates`): the innovation depends on the error only,

    ΔY_k/√h − √h·Z_f,1 = −√h·e_f,1 + σ·ε_k =: u                      (B.34, A.18)

so with the filter's propagation ``A_f = A0 − a_f EEᵀ`` and ``A_f − A = (α − a_f) EEᵀ``

    e_f ← (I + h·A_f)·e_f + h(α − a_f)·X_m·E − β√h·v_k·E + √h·φ_f(u)     (B.30 / A.18 minus B.33)
    X   ← (I + h A)·X + β E √h·v_k                                      (B.33)

X_m is stationary for α > 0 (and unused when α = a_f), so the errors keep every digit whatever the size of
X_1 ~ t^{m−½}: integrating X and Z separately and subtracting loses them all at high order (m = 6, 2000/r_min:
the optimal filter's ratio came out 1262 instead of 1). X_1 … X_{m−1} are integrated only when the trajectory is
stored (``store``); the squared errors and the innovations never need them.

φ_f has one of three kinds (``kind[f]``, :data:`isl_core.filters.KIND_LINEAR` …): linear ``K u`` (B.30), the
power law of (A.17), or adaptive — linear with the gain K(σ̂_{k−1}) of an online estimate of σ, after which
the estimate takes in u_k (:mod:`isl_core.filters.adaptive`):

    v_k = v_{k−1} + λ_k (u_k² − v_{k−1}),  λ_k = max(1/k, 1/W)       (innovation variance, Mehra 1970)
    σ̂_k² = v_k / (1 + h·K_1(σ̂_{k−1}))                                 (E u² = σ² + h·E e_1², e_1 ≈ Δ_11 = σ²K_1)
    log K_i(σ̂_k): linear interpolation in log σ̂ on a table, held at its ends

Squared errors e_f,i² are summed per batch: into a per-call accumulator that is flushed into ``sq`` every
:data:`FLUSH` steps and at every batch edge, so a sum over n steps carries a rounding error of at most
≈ (FLUSH + n/FLUSH)·eps relative (≈ 6e-12 for 2·10⁸ steps), not n·eps. The kernel trusts its inputs (validated
in :mod:`isl_core.simulate`).

The root of the power law, the adaptive gain's table lookup and the flush interval are shared with the scenario
loop (:mod:`isl_core.kernels.common`); how the kernels are compiled and cached: :mod:`isl_core.kernels.cache`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..filters.base import KIND_ADAPTIVE, KIND_POWER
from .cache import CACHE, FASTMATH, njit
from .common import AD_INV_MEMORY, AD_SIGMA, AD_VAR, FLUSH, root, table_gain

if TYPE_CHECKING:
    from .bundles import Batches, Buckets, FilterBank, Grid, Trajectory, Tube

__all__ = ["TRACE_ERROR", "TRACE_ESTIMATE", "TRACE_SIGMA", "TRACE_TRUTH", "advance", "minmax_block"]

#: the traces of a display run, in column order (:func:`minmax_block`): X_i, X_i + e_f,i, e_f,i, σ̂ of a σ-learner
TRACE_TRUTH, TRACE_ESTIMATE, TRACE_ERROR, TRACE_SIGMA = range(4)


@njit(cache=CACHE, nogil=True, inline="always")
def _flush(
    acc: np.ndarray, sacc: np.ndarray, sq: np.ndarray, sig_sum: np.ndarray, b: int, slot: np.ndarray, kind: np.ndarray
) -> None:
    """Add the accumulated squared errors (and σ̂ sums) into batch ``b`` and zero the accumulators."""
    nf, m = acc.shape
    for f in range(nf):
        for i in range(m):
            sq[b, f, i] += acc[f, i]
            acc[f, i] = 0.0
        if kind[f] == KIND_ADAPTIVE:
            sig_sum[b, slot[f]] += sacc[f]
            sacc[f] = 0.0


@njit(cache=CACHE, nogil=True, fastmath=FASTMATH)
def advance(
    x: np.ndarray,
    e: np.ndarray,
    rng: np.random.Generator,
    n: int,
    k0: int,
    grid: Grid,
    sigma: float,
    bank: FilterBank,
    batches: Batches,
    out: Trajectory,
) -> int:
    """Advance truth ``x`` (m,) and the filters' errors ``e`` (nf, m) in place by ``n`` steps k0 → k0 + n on the
    :class:`~isl_core.kernels.bundles.Grid` ``grid``, with the observation noise σ·ε_k, noise from ``rng``.

    ``bank`` (:class:`~isl_core.kernels.bundles.FilterBank`): ``kind[f]`` selects φ — :data:`KIND_LINEAR` gain
    ``coef``, :data:`KIND_POWER` power law with ``coef``, :data:`KIND_ADAPTIVE` — and an adaptive filter reads its
    table of log K ``table[f]`` (nt ≥ 2, m) and carries its state in ``ad[f]`` (columns ``AD_*``); the a-th
    adaptive filter (in filter order) is slot a of the σ̂ sums and rows. ``batches``
    (:class:`~isl_core.kernels.bundles.Batches`): for every new step k+1 > ``burn``, the squared errors go to
    ``sq[b, f, i]`` (and σ̂ to ``sig_sum[b, a]``) with ``b = min((k+1−burn−1) // length, nb−1)``. ``out``
    (:class:`~isl_core.kernels.bundles.Trajectory`): if ``store``, the whole truth is integrated and X(t_{k+1}),
    e_f(t_{k+1}) and σ̂ are written to row k+1−``first`` of ``X``, ``E[f]`` and ``S[a]``; otherwise only X_m is
    advanced (x[:m−1] is left as it was). Returns the number of steps done; it stops early at the first step that
    leaves a non-finite value in the truth or an error.
    """
    h, alpha, beta = grid
    damp, coef, kind, table, ad = bank
    burn, batch_len, sq, sig_sum = batches
    store, out0, X_out, E_out, S_out = out
    m = x.shape[0]
    nf = e.shape[0]
    nb = sq.shape[0]
    sqh = math.sqrt(h)
    beta_sqh = beta * sqh
    decay = 1.0 - h * alpha  # (I + hA) on X_m
    zdecay = 1.0 - h * damp  # (I + h(A0 − a_f EEᵀ)) on e_f,m
    couple = h * (alpha - damp)  # h(A_f − A)X = h(α − a_f)·X_m·E
    gain = sqh * coef  # √h·φ carries √h
    slot = np.zeros(nf, dtype=np.int64)
    uu = np.zeros(nf)
    acc = np.zeros((nf, m))
    sacc = np.zeros(nf)
    na = 0
    for f in range(nf):
        if kind[f] == KIND_ADAPTIVE:
            slot[f] = na
            na += 1
            table_gain(table, ad, f, gain, sqh)  # K(σ̂) of the state carried in
    # batch of the next step, and the last step of that batch (counters instead of a division per step)
    b = min(max(k0 - burn, 0) // batch_len, nb - 1)
    edge = burn + (b + 1) * batch_len
    pending = 0  # steps in the accumulators
    for j in range(n):
        k = k0 + j + 1
        v = rng.standard_normal()
        noise = sigma * rng.standard_normal()  # σ·ε_k: the part of ΔY/√h that no filter predicts   (B.34)
        xm = x[m - 1]
        shock = beta_sqh * v  # −β√h·v·E: the signal's step that no filter predicts   (B.33)
        total = 0.0
        for f in range(nf):
            u = noise - sqh * e[f, 0]  # innovation of (A.18) in error coordinates (:ref:`error-coordinates`)
            for i in range(m - 1):  # (I + h A0) e: ascending order uses the old e_{i+1}
                e[f, i] += h * e[f, i + 1]
            e[f, m - 1] = zdecay[f] * e[f, m - 1] + couple[f] * xm - shock
            if kind[f] == KIND_POWER:
                p = np.float64(u > 0.0) - np.float64(u < 0.0)  # sign(u), branch-free
                r = root(abs(u), m)
                for i in range(m - 1, -1, -1):  # c_i sign(u)|u|^{1-(i+1)/m} = c_i sign(u) r^{m-1-i}   (A.17)
                    e[f, i] += gain[f, i] * p
                    total += e[f, i]
                    p *= r
            else:
                for i in range(m):  # linear gain: K(ΔY − h Z_1) = √h·K·u   (B.30)
                    e[f, i] += gain[f, i] * u
                    total += e[f, i]
                if kind[f] == KIND_ADAPTIVE:
                    uu[f] = u  # its σ̂ update runs below, outside this loop: the KBF/ISL path stays lean
        if na > 0:  # adaptive filters: take u_k into σ̂, then the gain of the next step
            for f in range(nf):
                if kind[f] == KIND_ADAPTIVE:
                    u = uu[f]
                    var = ad[f, AD_VAR]
                    var += max(1.0 / k, ad[f, AD_INV_MEMORY]) * (u * u - var)  # EWMA of u²
                    ad[f, AD_VAR] = var
                    s_hat = math.sqrt(var / (1.0 + sqh * gain[f, 0]))  # σ̂² = v/(1 + h K_1)
                    ad[f, AD_SIGMA] = s_hat
                    table_gain(table, ad, f, gain, sqh)
                    if k > burn:
                        sacc[f] += s_hat
                    if store:
                        S_out[slot[f], k - out0] = s_hat
        if store:
            for i in range(m - 1):  # (B.33)
                x[i] += h * x[i + 1]
            total += x[0]
        x[m - 1] = decay * xm + shock
        total += x[m - 1]
        if k > burn:
            for f in range(nf):
                for i in range(m):
                    d = e[f, i]
                    acc[f, i] += d * d
            pending += 1
            if k == edge or pending == FLUSH:
                _flush(acc, sacc, sq, sig_sum, b, slot, kind)
                pending = 0
                if k == edge and b < nb - 1:
                    b += 1
                    edge += batch_len
        if store:
            for i in range(m):
                X_out[k - out0, i] = x[i]
            for f in range(nf):
                for i in range(m):
                    E_out[f, k - out0, i] = e[f, i]
        if not math.isfinite(total):
            _flush(acc, sacc, sq, sig_sum, b, slot, kind)
            return j + 1
    _flush(acc, sacc, sq, sig_sum, b, slot, kind)
    return n


@njit(cache=CACHE, nogil=True, inline="always")
def _source(c: int, m: int, nf: int) -> tuple[int, int, int]:
    """What trace (column) ``c`` is: (kind, f, i), kind one of ``TRACE_*``."""
    if c < m:
        return TRACE_TRUTH, 0, c
    if c < m * (1 + nf):
        f, i = divmod(c - m, m)
        return TRACE_ESTIMATE, f, i
    if c < m * (1 + 2 * nf):
        f, i = divmod(c - m * (1 + nf), m)
        return TRACE_ERROR, f, i
    return TRACE_SIGMA, c - m * (1 + 2 * nf), 0


@njit(cache=CACHE, nogil=True, inline="always")
def _sample(X: np.ndarray, E: np.ndarray, S: np.ndarray, kind: int, f: int, i: int, r: int) -> float:
    """Value at row r of the trace (kind, f, i) of :func:`_source`."""
    if kind == TRACE_TRUTH:
        return float(X[r, i])
    if kind == TRACE_ESTIMATE:
        return float(X[r, i] + E[f, r, i])
    if kind == TRACE_ERROR:
        return float(E[f, r, i])
    return float(S[f, r])


@njit(cache=CACHE, nogil=True)
def minmax_block(X: np.ndarray, E: np.ndarray, S: np.ndarray, k0: int, n: int, buckets: Buckets, tube: Tube) -> None:
    """Fold one chunk of a display run into its min/max buckets (:class:`isl_core.decimate.MinMax`), without the GIL.

    Rows r of ``X`` (rows, m), ``E`` (nf, rows, m), ``S`` (na, rows) are the samples k = k0 + r of n in all. The
    traces, in column order (``TRACE_*``): X_i; the estimates X_i + e_f,i; the errors e_f,i; σ̂ of each adaptive
    filter. ``buckets`` (:class:`~isl_core.kernels.bundles.Buckets`): sample 0 and n − 1 go to ``ends``; interior
    sample k to bucket (k − 1) // size, where a strictly smaller (larger) value replaces the bucket's min (max): ties
    keep the earlier sample, as ``argmin`` does. ``tube`` (:class:`~isl_core.kernels.bundles.Tube`): for k ≥ 1,
    counts ``|e_f,i| ≤ bound_i`` into ``inside`` (nf, m) and sums σ̂ into ``sig_sum`` (na,).

    Each trace is walked through the chunk with its current bucket's extremes in registers (written back when the
    bucket ends and at the end of the chunk), and the bucket advanced by a counter, not a division per sample.
    """
    size, lo_v, lo_i, hi_v, hi_i, ends = buckets
    bound, inside, sig_sum = tube
    rows, m = X.shape
    nf = E.shape[0]
    na = S.shape[0]
    first = max(k0, 1)  # the chunk's first interior sample
    last = min(k0 + rows, n - 1)  # one past its last
    for c in range(m * (1 + 2 * nf) + na):
        kind, f, i = _source(c, m, nf)
        if k0 == 0:
            ends[0, c] = _sample(X, E, S, kind, f, i, 0)
        if k0 + rows == n:
            ends[1, c] = _sample(X, E, S, kind, f, i, rows - 1)
        if first >= last:
            continue
        b = (first - 1) // size
        edge = 1 + (b + 1) * size  # first sample of the next bucket
        lo, li, hi, hj = lo_v[b, c], lo_i[b, c], hi_v[b, c], hi_i[b, c]
        for k in range(first, last):
            if k == edge:
                lo_v[b, c], lo_i[b, c], hi_v[b, c], hi_i[b, c] = lo, li, hi, hj
                b += 1
                edge += size
                lo, li, hi, hj = lo_v[b, c], lo_i[b, c], hi_v[b, c], hi_i[b, c]
            v = _sample(X, E, S, kind, f, i, k - k0)
            if v < lo:
                lo, li = v, k
            if v > hi:
                hi, hj = v, k
        lo_v[b, c], lo_i[b, c], hi_v[b, c], hi_i[b, c] = lo, li, hi, hj
    for r in range(max(1 - k0, 0), rows):  # steps k ≥ 1: the tube count and the σ̂ sum
        for f in range(nf):
            for i in range(m):
                if abs(E[f, r, i]) <= bound[i]:
                    inside[f, i] += 1
        for a in range(na):
            sig_sum[a] += S[a, r]
