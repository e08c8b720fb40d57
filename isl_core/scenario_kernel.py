"""The compiled time loop of a scenario run (SPEC §8–§9): σ_k per step, the noise law, the sensor interval.

The same error coordinates as :func:`isl_core.kernels.advance` — e_f = Z_f − X per filter, the truth's X_m only —
with three changes. σ_k comes from the scenario's path (``sig``, one value per step); ε_k from its law (``law``:
0 Gaussian, 1 Student-t scaled to unit variance, 2 Gaussian with outliers); and the filters take in an
observation only every ``q`` steps, the increment of Y over those steps. Each filter f accumulates

    a_f += σ_k·ε_k − √h·e_f,1          (so that √h·a_f = ΔY − the increment its estimates predict, B.34)

and at a reading (global step k with (k + 1) mod q = 0) takes in the normalized innovation u = a_f/√q, the
innovation of one step of length qh divided by √(qh), then restarts a_f at 0:

    linear (kind 0):       e_f += √(qh)·K·u                                       (B.30)
    power law (kind 1):    e_f += √(qh)·φ(u)                                      (A.17–A.18)
    adaptive (kind 2):     e_f += √(qh)·K(σ̂)·u, then σ̂ takes in u                 (isl_core.adaptive)
    clairvoyant (kind 3):  e_f += √h·a_f·K_k, K_k its recursion's gain at step k  (isl_core.scenario.clairvoyant)
    variational (kind 4):  e_f += F·K·u, K from a few fixed-point iterations      (isl_core.variational)
    robust (kind 5):       e_f += √(qh)·K(σ̂)·ψ(u), ψ Huber's clip at ±c·σ̂       (isl_core.robust)

The variational-Bayes filter carries its covariance ``vb_P[f]`` (predicted every step, updated at readings) and
its inverse-gamma parameters ``vb_ab[f]`` (a, b; forgotten by ρ^q at each reading), ``vb_par[f]`` = (ρ per step,
iterations); for a robust filter ``vb_par[f]`` = (c, κ(c)).

Between readings the filters only propagate, e_f ← (I + h·A_f)·e_f + h(α − a_f)·X_m·E − β√h·v_k·E. With q = 1 the
power-law and linear updates are those of :func:`isl_core.kernels.advance`. The adaptive estimator's forgetting
factor is max(1/r, q/W) for the r-th reading: its window keeps its length in time.

Draws per step from the caller's generator: v_k, then ε_k of the law (:mod:`isl_core.noise`), drawn
:data:`isl_core.noise.DRAWS` steps ahead. Squared errors at t_{k+1} are summed into window (k // ``win``) (the last
window takes the remainder), σ̂ likewise.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .kernels import AD_INV_WINDOW, AD_SIGMA, AD_VAR, CACHE, FLUSH, _root, _table_gain
from .noise import DRAWS, draw_ahead
from .scenario import clairvoyant_step

__all__ = ["KIND_CLAIRVOYANT", "advance_scenario"]

KIND_CLAIRVOYANT = 3


@njit(cache=CACHE, nogil=True)
def _predict_cov(P, h, a, q_var):
    """P ← F P Fᵀ + q_var·E Eᵀ, F = I + h·(A0 − a·E Eᵀ), in place (F is bidiagonal: O(m²))."""
    m = P.shape[0]
    for j in range(m):  # rows: F P
        for i in range(m - 1):
            P[i, j] += h * P[i + 1, j]
        P[m - 1, j] *= 1.0 - h * a
    for i in range(m):  # columns: (F P) Fᵀ
        for j in range(m - 1):
            P[i, j] += h * P[i, j + 1]
        P[i, m - 1] *= 1.0 - h * a
    P[m - 1, m - 1] += q_var


@njit(cache=CACHE, nogil=True)
def _vb_update(P, ab, par, u, H, h, a_f, gvec):
    """One reading of the variational-Bayes filter: updates P and (a, b) in place, writes F·K into ``gvec``;
    returns σ̂ = √(b/a)."""
    m = P.shape[0]
    rho_q = 1.0 - (1.0 - par[0]) * (H * H / h)  # ρ per reading: 1 − q(1 − ρ), qh = H²
    a = rho_q * ab[0] + 0.5
    b_pr = rho_q * ab[1]
    b = b_pr
    p11 = P[0, 0]
    k1 = 0.0
    s = 1.0
    for _ in range(int(par[1])):
        s = H * H * p11 + b / a
        k1 = P[0, 0] * H / s
        resid = u * (1.0 - H * k1)
        b = b_pr + 0.5 * resid * resid + 0.5 * H * H * (p11 - k1 * s * k1)
    for i in range(m):
        gvec[i] = P[i, 0] * H / s
    for i in range(m):
        for j in range(m):
            P[i, j] -= gvec[i] * s * gvec[j]
    for i in range(m - 1):  # F·K
        gvec[i] += h * gvec[i + 1]
    gvec[m - 1] *= 1.0 - h * a_f
    ab[0], ab[1] = a, b
    return np.sqrt(b / a)


@njit(cache=CACHE, nogil=True)
def _pour(wref, w, cvar, s_cur, same):
    """Add ``same`` steps of clairvoyant variance ``cvar`` and σ_k = ``s_cur`` to window ``w``."""
    m = cvar.shape[0]
    for i in range(m):
        wref[w, i] += cvar[i] * same
    wref[w, m] += s_cur * same


@njit(cache=CACHE, nogil=True)
def _flush(wsq, w, sq):
    """Add the squared errors summed since the last flush to window ``w`` and restart the sums."""
    for f in range(sq.shape[0]):
        for i in range(sq.shape[1]):
            wsq[w, f, i] += sq[f, i]
            sq[f, i] = 0.0


@njit(cache=CACHE, nogil=True)
def _bury(e, died, k):
    """Mark every live filter whose error is no longer finite as dead at step ``k``."""
    for f in range(e.shape[0]):
        if died[f] < 0:
            total = 0.0
            for i in range(e.shape[1]):
                total += e[f, i]
            if not math.isfinite(total):
                died[f] = k


@njit(cache=CACHE, nogil=True, fastmath={"contract"})
def advance_scenario(x, e, rng, n, h, alpha, beta, sig, law, dof, ztab, p_out, k_out, q, damp, coef, kind, table, ad,
                     clair, acc, k0, win, wsq, wsig, wref, vb_P, vb_ab, vb_par, died):
    """Advance X_m (``x``, m,) and the errors ``e`` (nf, m) by ``n`` steps (global steps k0 … k0 + n − 1).

    ``sig`` (n,) is this chunk's σ_k, or (1,) its one σ while σ is constant; ``clair`` = (P, st, cg, cvar, cycle P,
    cycle R, E ε²) the clairvoyant recursion's state (:func:`isl_core.scenario.clairvoyant_step`, run here in line, once
    per step: its gain ``cg`` serves the clairvoyant filter, kind 3), and ``wref`` (nw, m + 1) sums its diag P at
    t_{k+1} and σ_k per window; ``acc`` (nf,) the filters' accumulated innovations carried from chunk to chunk;
    ``ad`` the adaptive filters' state (as in :func:`isl_core.kernels.advance`). A filter whose error leaves the
    finite numbers at step k is stopped there: ``died[f] = k`` (−1 while it lives), its error is no longer advanced
    nor summed, the others go on. The σ-learning filters take in a reading's u² after every filter has taken in its
    innovation (their gain at a reading uses the σ̂ before it): out of the filters' loop, which stays lean for the
    others (measured: 5-10 ns a step). Returns the number of steps done (fewer only if the truth itself leaves the
    finite numbers).
    """
    m = x.shape[0]
    nf = e.shape[0]
    nw = wsq.shape[0]
    sqh = math.sqrt(h)
    sqq = math.sqrt(q)
    sqqh = math.sqrt(q * h)
    beta_sqh = beta * sqh
    decay = 1.0 - h * alpha
    zdecay = 1.0 - h * damp
    couple = h * (alpha - damp)
    gain = sqqh * coef
    vbuf, ebuf = np.empty(DRAWS), np.empty(DRAWS)
    slot = np.zeros(nf, dtype=np.int64)
    stride = 0 if sig.shape[0] == 1 else 1
    sq = np.zeros((nf, m))  # squared errors since the last flush into wsq (FLUSH steps at most, as kernels.advance)
    pending = 0
    gvec = np.zeros(m)
    uus = np.zeros(nf)
    q_var = h * beta * beta
    na = 0
    for f in range(nf):
        if kind[f] == 2 or kind[f] == 4 or kind[f] == 5:
            slot[f] = na
            na += 1
        if kind[f] == 2 or kind[f] == 5:
            _table_gain(table, ad, f, gain, sqqh)
    cP, cst, cg, cvar, cyc, cyc_r, nv = clair
    beta2 = beta * beta
    w = min(k0 // win, nw - 1)  # the window of this step's errors, and the first step of the next one
    edge = (w + 1) * win if w < nw - 1 else k0 + n + 1
    left = q - k0 % q  # steps until the next reading, this one included
    # steps not yet summed into wref, all with the clairvoyant variance ``cvar`` and σ_k = ``s_cur``: while the
    # recursion is settled and σ_k stays, both repeat, and are summed once, times ``same``
    same, s_cur = 0, sig[0]
    for j in range(n):
        k = k0 + j
        if k == edge:
            _pour(wref, w, cvar, s_cur, same)
            _flush(wsq, w, sq)
            same, pending = 0, 0
            w += 1
            edge = (w + 1) * win if w < nw - 1 else k0 + n + 1
        b = j % DRAWS
        if b == 0:
            draw_ahead(rng, law, dof, ztab, p_out, k_out, vbuf, ebuf, min(DRAWS, n - j))
        v = vbuf[b]
        eps = ebuf[b]
        s_k = sig[j * stride]
        noise = s_k * eps
        c_noise = h * (s_k * s_k) * nv
        # settled while σ_k stays (clairvoyant_step): with a reading every step, nothing to do; with q > 1 the
        # variance follows the sensor cycle, and is read back here at this step's phase (a call per step, with its
        # arrays' reference counts, cost 20-30 ns a step)
        if cst[1] != 0.0 and c_noise == cst[2]:
            if q > 1:
                if same > 0:
                    _pour(wref, w, cvar, s_cur, same)
                    same = 0
                for i in range(m):
                    wref[w, i] += cyc[q - left, i, i]
                wref[w, m] += s_k
            else:
                same += 1
        else:
            _pour(wref, w, cvar, s_cur, same)  # the steps since the last change, then the new one
            same, s_cur = 1, s_k
            clairvoyant_step(cP, cst, cg, cvar, cyc, cyc_r, h, decay, beta2, c_noise, k, q, q - left)
        xm = x[m - 1]
        shock = beta_sqh * v
        reading = left == 1
        left = q if reading else left - 1
        total = 0.0
        for f in range(nf):
            if died[f] >= 0:
                continue
            if q == 1:  # a reading at every step: the innovation of this step (as isl_core.kernels.advance)
                u = noise - sqh * e[f, 0]
            else:
                acc[f] += noise - sqh * e[f, 0]
            for i in range(m - 1):
                e[f, i] += h * e[f, i + 1]
            e[f, m - 1] = zdecay[f] * e[f, m - 1] + couple[f] * xm - shock
            if reading:
                if q > 1:
                    u = acc[f] / sqq
                if kind[f] == 1:
                    p = np.float64(u > 0.0) - np.float64(u < 0.0)
                    r = _root(abs(u), m)
                    for i in range(m - 1, -1, -1):
                        e[f, i] += gain[f, i] * p
                        p *= r
                elif kind[f] == 3:
                    a_f = acc[f] if q > 1 else u
                    for i in range(m):
                        e[f, i] += cg[i] * (sqh * a_f)
                elif kind[f] == 4:
                    ad[f, AD_SIGMA] = _vb_update(vb_P[f], vb_ab[f], vb_par[f], u, sqqh, h, damp[f], gvec)
                    for i in range(m):
                        e[f, i] += gvec[i] * u
                else:
                    uc, uu = u, u * u
                    if kind[f] == 5:  # Huber: clip at ±c·σ̂ (the estimate before this reading)
                        lim = vb_par[f, 0] * ad[f, AD_SIGMA]
                        uc = min(max(u, -lim), lim)
                        uu = min(uu, lim * lim) / vb_par[f, 1]
                    for i in range(m):
                        e[f, i] += gain[f, i] * uc
                    uus[f] = uu
                acc[f] = 0.0
            if kind[f] == 4:
                _predict_cov(vb_P[f], h, damp[f], q_var)
            for i in range(m):  # (a filter that leaves the finite numbers here: its window is set to inf after)
                d = e[f, i]
                total += d
                sq[f, i] += d * d
        if na > 0:  # the σ-learning filters: σ̂ takes in this reading's u² (after their gain used the σ̂ before)
            for f in range(nf):
                if died[f] >= 0:
                    continue
                if reading and (kind[f] == 2 or kind[f] == 5):
                    r_k = (k + 1) // q
                    var = ad[f, AD_VAR]
                    var += max(1.0 / r_k, q * ad[f, AD_INV_WINDOW]) * (uus[f] - var)
                    ad[f, AD_VAR] = var
                    ad[f, AD_SIGMA] = math.sqrt(var / (1.0 + sqqh * gain[f, 0]))
                    _table_gain(table, ad, f, gain, sqqh)
                if kind[f] == 2 or kind[f] == 4 or kind[f] == 5:
                    wsig[w, slot[f]] += ad[f, AD_SIGMA]
        pending += 1
        if pending == FLUSH:
            _flush(wsq, w, sq)
            pending = 0
        if not math.isfinite(total):  # some filter's error left the finite numbers at this step: stop it
            _bury(e, died, k)
        x[m - 1] = decay * xm + shock
        if not math.isfinite(x[m - 1]):
            _pour(wref, w, cvar, s_cur, same)
            _flush(wsq, w, sq)
            return j + 1
    _pour(wref, w, cvar, s_cur, same)
    _flush(wsq, w, sq)
    return n
