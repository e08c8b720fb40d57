"""The compiled time loop of a scenario run (:ref:`error-coordinates`, :ref:`scenarios`): σ_k per step, the noise law,
the sensor interval.

The same error coordinates as :func:`isl_core.kernels.euler.advance` — e_f = Z_f − X per filter, the truth's X_m
only — with three changes. σ_k comes from the scenario's path (``sigma``, one value per step); ε_k from its law
(``law``: ``LAW_GAUSSIAN``, ``LAW_STUDENT`` scaled to unit variance, ``LAW_OUTLIERS``); and the filters take in an
observation only every ``q`` steps, the increment of Y over those steps. Each filter f accumulates

    a_f += σ_k·ε_k − √h·e_f,1          (so that √h·a_f = ΔY − the increment its estimates predict, B.34)

and at a reading (global step k with (k + 1) mod q = 0) takes in the normalized innovation u = a_f/√q, the
innovation of one step of length qh divided by √(qh), then restarts a_f at 0:

    KIND_LINEAR:       e_f += √(qh)·K·u                                       (B.30)
    KIND_POWER:        e_f += √(qh)·φ(u)                                      (A.17–A.18)
    KIND_ADAPTIVE:     e_f += √(qh)·K(σ̂)·u, then σ̂ takes in u                 (isl_core.filters.adaptive)
    KIND_CLAIRVOYANT:  e_f += √h·a_f·K_k, K_k its recursion's gain at step k  (isl_core.scenario.clairvoyant)
    KIND_VB:           e_f += F·K·u, K from a few fixed-point iterations      (isl_core.filters.variational)
    KIND_ROBUST:       e_f += √(qh)·K(σ̂)·ψ(u), ψ Huber's clip at ±c·σ̂       (isl_core.filters.robust)
    KIND_IMM:          e_f += the bank's correction to Σ_j μ_j e_j            (isl_core.kernels.imm.imm_step)

The variational-Bayes filter carries its covariance ``vb_P[f]`` (predicted every step, updated at readings) and
its inverse-gamma parameters ``vb_ab[f]`` (a, b; forgotten by ρ = 1 − 1/W at each reading), ``vb_par[f]`` = (ρ per
reading, iterations); for a robust filter ``vb_par[f]`` = (c, κ(c)). The adaptive and robust filters keep in
``vb_ab[f]`` the σ range they state (σ_min, σ_max): their σ̂ is held inside it, and their running variance with it,
so that a run of large innovations cannot carry the estimate (and the gain) beyond what the filter assumes.

Between readings the filters only propagate, e_f ← (I + h·A_f)·e_f + h(α − a_f)·X_m·E − β√h·v_k·E. With q = 1 the
power-law and linear updates are those of :func:`isl_core.kernels.euler.advance`. The σ-learning filters' memory W
counts readings: the adaptive and robust estimators forget with λ = max(1/r, 1/W) at the r-th reading, the variational
one with ρ = 1 − 1/W (:mod:`isl_core.filters.adaptive`).

Every update above is e_f,i += G_f,i·p_f·r_f^(m−i) for i = m … 1 with a gain column G_f and a pair (p_f, r_f) of the
reading (:func:`reading_pair`): r_f = |u|^{1/m} and p_f = sign u for the power law, r_f = 1 and p_f = u (√h·a_f for
the clairvoyant filter, ψ(u) for the robust one) for the others. So the filters run in lanes of :data:`LANES` side
by side, the same arithmetic in the same order for each filter (runs equal those of the loop over the filters bit
for bit), and the processor overlaps the lanes' independent chains of arithmetic (:ref:`performance-scenario`).

Draws per step from the caller's generator: v_k, then ε_k of the law (:mod:`isl_core.noise`), drawn
:data:`isl_core.noise.DRAWS` steps ahead; on a grid refined ``obs.level`` times, per base step, split into its fine
steps by the Brownian bridge (:func:`isl_core.kernels.draws.split_ahead`: the same path as the base grid's).
Squared errors at t_{k+1} are summed into window w for the steps k in [``edges[w]``, ``edges[w + 1]``), σ̂ likewise.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..filters.base import (
    KIND_ADAPTIVE,
    KIND_CLAIRVOYANT,
    KIND_IMM,
    KIND_LINEAR,
    KIND_POWER,
    KIND_ROBUST,
    KIND_VB,
)
from .cache import CACHE, FASTMATH, njit
from .clairvoyant import clairvoyant_step
from .common import AD_INV_MEMORY, AD_SIGMA, AD_VAR, FLUSH, root, table_gain
from .draws import DRAWS, draw_ahead, split_ahead
from .imm import imm_step
from .variational import predict_cov, vb_update

if TYPE_CHECKING:
    from .bundles import ClairvoyantState, FilterBank, FilterState, Grid, IMMState, Observation, Windows

__all__ = ["advance_scenario", "reading_pair"]

LANES = 4  #: filters advanced side by side (:func:`advance_scenario`)
IDLE = -1  #: the kind of a lane without a filter, or whose filter died


@njit(cache=CACHE, nogil=True)
def _pour(wref: np.ndarray, w: int, cvar: np.ndarray, s_cur: float, same: int) -> None:
    """Add ``same`` steps of clairvoyant variance ``cvar`` and σ_k = ``s_cur`` to window ``w``."""
    m = cvar.shape[0]
    for i in range(m):
        wref[w, i] += cvar[i] * same
    wref[w, m] += s_cur * same


@njit(cache=CACHE, nogil=True)
def _flush(wsq: np.ndarray, w: int, sq: np.ndarray) -> None:
    """Add the squared errors summed since the last flush, ``sq`` (m, lanes), to window ``w`` of each filter and
    restart the sums (the padding lanes' are dropped)."""
    for f in range(wsq.shape[1]):
        for i in range(sq.shape[0]):
            wsq[w, f, i] += sq[i, f]
    sq[:, :] = 0.0


@njit(cache=CACHE, nogil=True)
def _bury(e: np.ndarray, died: np.ndarray, lane: np.ndarray, k: int) -> None:
    """Mark every live filter whose error (a column of ``e``, (m, lanes)) is no longer finite as dead at step ``k``:
    its lane goes idle (no update) from a zero error, which nothing reads (its windows from then on are inf)."""
    for f in range(died.shape[0]):
        if died[f] < 0:
            total = 0.0
            for i in range(e.shape[0]):
                total += e[i, f]
            if not math.isfinite(total):
                died[f] = k
                lane[f] = IDLE
                e[:, f] = 0.0


@njit(cache=CACHE, nogil=True, inline="always")
def reading_pair(kind: int, u: float, raw: float, sqh: float, own: float, lim: float, m: int) -> tuple[float, float]:
    """(p, r) of a lane's update at a reading, e_i += G_i·p·r^(m−i) for i = m … 1 (module docstring); ``raw`` the
    innovation before its normalization by √q, ``own`` the learning filters' u (taken before the lanes' pass)."""
    if kind == KIND_POWER:
        return np.float64(u > 0.0) - np.float64(u < 0.0), root(abs(u), m)
    if kind == KIND_LINEAR:
        return u, 1.0
    if kind == KIND_CLAIRVOYANT:
        return sqh * raw, 1.0
    if kind == KIND_ROBUST:
        return min(max(own, -lim), lim), 1.0
    if kind == IDLE:
        return 0.0, 1.0
    return own, 1.0


@njit(cache=CACHE, nogil=True, fastmath=FASTMATH)
def advance_scenario(
    x: np.ndarray,
    e: np.ndarray,
    rng: np.random.Generator,
    n: int,
    k0: int,
    grid: Grid,
    obs: Observation,
    bank: FilterBank,
    state: FilterState,
    clair: ClairvoyantState,
    imm: IMMState,
    windows: Windows,
) -> int:
    """Advance X_m (``x``, m,) and the errors ``e`` (nf, m) by ``n`` steps (global steps k0 … k0 + n − 1).

    The arguments are bundles (:mod:`isl_core.kernels.bundles`): ``grid`` the truth's Euler grid; ``obs`` this
    chunk's σ_k (n,) — or (1,), its one σ while σ is constant —, the noise law and the sensor steps q; ``bank`` the
    filters (``ad`` the σ-learners' state, as in :func:`isl_core.kernels.euler.advance`); ``state`` what each filter
    carries from chunk to chunk (innovations since its last reading, death, the variational filters' state);
    ``clair`` the clairvoyant recursion's state (:func:`isl_core.kernels.clairvoyant.clairvoyant_step`, run here in
    line, once per step: its gain serves the clairvoyant filter, :data:`KIND_CLAIRVOYANT`); ``imm`` the IMM banks;
    ``windows`` the sums per window, ``ref`` the clairvoyant diag P at t_{k+1} and σ_k. A filter whose error leaves
    the finite numbers at step k is stopped there: ``died[f] = k`` (−1 while it lives), its lane goes idle (what it
    sums from then on lands in windows the run sets to inf), the others go on. Returns the number of steps done
    (fewer only if the truth itself leaves the finite numbers).

    The filters run in lanes of four (the last ones padded with idle lanes): errors ``el`` (m, lanes),
    gains ``G`` (m, lanes: √(qh)·K, the power law's coefficients, the clairvoyant gain, the variational filter's
    F·K). The σ-learning filters take their reading's u before the lanes' pass (the variational filter's gain of
    this reading needs it) and take in u² after it (their gain at a reading uses the σ̂ before it). The IMM banks
    (``imm``: :func:`isl_core.kernels.imm.imm_state`) step before the lanes' pass, and at a reading give their lane its
    update (p = 1, G = the correction).
    """
    h, alpha, beta = grid
    sig, law, q, bridge, level = obs
    damp, coef, kind, table, ad = bank
    acc, died, vb_P, vb_ab, vb_par = state
    edges, wsq, wsig, wref = windows
    m = x.shape[0]
    nf = e.shape[0]
    nw = wsq.shape[0]
    nl = LANES * ((nf + LANES - 1) // LANES)
    sqh = math.sqrt(h)
    sqq = math.sqrt(q)
    sqqh = math.sqrt(q * h)
    beta_sqh = beta * sqh
    decay = 1.0 - h * alpha
    gain = sqqh * coef
    block = DRAWS << level  # fine steps whose noise is drawn at once: DRAWS base steps
    vbuf, ebuf = np.empty(block), np.empty(block)
    vbase, ebase = np.empty(DRAWS), np.empty(DRAWS)
    el, G, sq = np.zeros((m, nl)), np.zeros((m, nl)), np.zeros((m, nl))
    zd, cp = np.full(nl, decay), np.zeros(nl)  # idle lanes: the truth's own decay, e = −X from 0
    lane = np.full(nl, IDLE, dtype=np.int64)
    accl, own, lim = np.zeros(nl), np.zeros(nl), np.zeros(nl)
    learn = np.zeros(nf, dtype=np.int64)  # the σ-learning filters, in order: slot a is learn[a]
    clairs = np.zeros(nf, dtype=np.int64)
    imms = np.zeros(nf, dtype=np.int64)
    islot = imm.slot
    corr = np.zeros(m)
    na, nc, ni = 0, 0, 0
    for f in range(nf):
        zd[f], cp[f] = 1.0 - h * damp[f], h * (alpha - damp[f])
        accl[f] = acc[f]
        if died[f] >= 0:
            continue
        lane[f] = kind[f]
        for i in range(m):
            el[i, f] = e[f, i]
        if kind[f] == KIND_ADAPTIVE or kind[f] == KIND_ROBUST:
            table_gain(table, ad, f, gain, sqqh)
        if kind[f] == KIND_CLAIRVOYANT:
            clairs[nc] = f
            nc += 1
        if kind[f] == KIND_IMM:
            imms[ni] = f
            ni += 1
            own[f] = 1.0
        if kind[f] == KIND_ADAPTIVE or kind[f] == KIND_VB or kind[f] == KIND_ROBUST or kind[f] == KIND_IMM:
            learn[na] = f
            na += 1
        G[:, f] = gain[f]
    cst, cg, cvar, cyc, nv = clair.flags, clair.gain, clair.var, clair.cycle_P, law.variance
    for c in range(nc):
        G[:, clairs[c]] = cg
    gvec = np.zeros(m)
    q_var = h * beta * beta
    stride = 0 if sig.shape[0] == 1 else 1
    pending = 0
    beta2 = beta * beta
    w = 0  # the window of this step's errors, and the first step of the next one
    while w < nw - 1 and edges[w + 1] <= k0:
        w += 1
    edge = edges[w + 1] if w < nw - 1 else k0 + n + 1
    left = q - k0 % q  # steps until the next reading, this one included
    # steps not yet summed into wref, all with the clairvoyant variance ``cvar`` and σ_k = ``s_cur``: while the
    # recursion is settled and σ_k stays, both repeat, and are summed once, times ``same``
    same, s_cur = 0, sig[0]
    done = n
    for j in range(n):
        k = k0 + j
        if k == edge:
            _pour(wref, w, cvar, s_cur, same)
            _flush(wsq, w, sq)
            same, pending = 0, 0
            w += 1
            edge = edges[w + 1] if w < nw - 1 else k0 + n + 1
        b = j % block
        if b == 0:
            if level == 0:
                draw_ahead(rng, law, vbuf, ebuf, min(DRAWS, n - j))
            else:  # the base steps' draws, split by the bridge: the coarse grid's path (isl_core.kernels.draws)
                count = min(DRAWS, (n - j) >> level)
                split_ahead(rng, law, vbase, ebase, bridge, j >> level, count, level, vbuf, ebuf)
        s_k = sig[j * stride]
        noise = s_k * ebuf[b]
        c_noise = h * (s_k * s_k) * nv
        # settled while σ_k stays (clairvoyant_step): with a reading every step, nothing to do; with q > 1 the
        # variance follows the sensor cycle, and is read back here at this step's phase (in line: a call per step
        # would pass its arrays' reference counts every step)
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
            clairvoyant_step(clair, h, decay, beta2, c_noise, k, q, q - left)
            for c in range(nc):
                G[:, clairs[c]] = cg
        xm = x[m - 1]
        shock = beta_sqh * vbuf[b]
        reading = left == 1
        left = q if reading else left - 1
        for c in range(ni):  # the IMM banks: every step; at a reading their lane's update
            f = imms[c]
            if lane[f] != IDLE:
                bk = islot[f]
                s_hat = imm_step(imm, bk, el, f, noise, sqh, h, decay, q_var, shock, reading, corr)
                if reading:
                    G[:, f] = corr
                    ad[f, AD_SIGMA] = s_hat
        if reading:  # the σ-learning filters' u, before the lanes move: the variational filter's gain needs it
            for a in range(na):
                f = learn[a]
                if lane[f] == IDLE or kind[f] == KIND_IMM:
                    continue
                u = noise - sqh * el[0, f]
                if q > 1:
                    u = (accl[f] + u) / sqq
                own[f] = u
                if kind[f] == KIND_VB:
                    ad[f, AD_SIGMA] = vb_update(vb_P[f], vb_ab[f], vb_par[f], u, sqqh, h, damp[f], gvec)
                    G[:, f] = gvec
                elif kind[f] == KIND_ROBUST:  # Huber: clip at ±c·σ̂ (the estimate before this reading)
                    lim[f] = vb_par[f, 0] * ad[f, AD_SIGMA]
        total = 0.0
        # four lanes side by side, written out lane by lane: four independent chains of arithmetic in registers,
        # which the processor overlaps — faster than one filter after another (the branches and reloads of a loop
        # over the filters), an inlined function or a loop over range(0, nl, LANES) (:ref:`performance-scenario`)
        for g in range(nl // LANES):
            l0 = LANES * g
            l1, l2, l3 = l0 + 1, l0 + 2, l0 + 3
            if q == 1:
                u0 = noise - sqh * el[0, l0]
                u1 = noise - sqh * el[0, l1]
                u2 = noise - sqh * el[0, l2]
                u3 = noise - sqh * el[0, l3]
                w0, w1, w2, w3 = u0, u1, u2, u3
            else:
                accl[l0] += noise - sqh * el[0, l0]
                accl[l1] += noise - sqh * el[0, l1]
                accl[l2] += noise - sqh * el[0, l2]
                accl[l3] += noise - sqh * el[0, l3]
                w0, w1, w2, w3 = accl[l0], accl[l1], accl[l2], accl[l3]
                u0, u1, u2, u3 = w0 / sqq, w1 / sqq, w2 / sqq, w3 / sqq
            for i in range(m - 1):  # (I + h·A0) e: ascending, each row reads the old next one
                el[i, l0] += h * el[i + 1, l0]
                el[i, l1] += h * el[i + 1, l1]
                el[i, l2] += h * el[i + 1, l2]
                el[i, l3] += h * el[i + 1, l3]
            el[m - 1, l0] = zd[l0] * el[m - 1, l0] + cp[l0] * xm - shock
            el[m - 1, l1] = zd[l1] * el[m - 1, l1] + cp[l1] * xm - shock
            el[m - 1, l2] = zd[l2] * el[m - 1, l2] + cp[l2] * xm - shock
            el[m - 1, l3] = zd[l3] * el[m - 1, l3] + cp[l3] * xm - shock
            if reading:
                p0, r0 = reading_pair(lane[l0], u0, w0, sqh, own[l0], lim[l0], m)
                p1, r1 = reading_pair(lane[l1], u1, w1, sqh, own[l1], lim[l1], m)
                p2, r2 = reading_pair(lane[l2], u2, w2, sqh, own[l2], lim[l2], m)
                p3, r3 = reading_pair(lane[l3], u3, w3, sqh, own[l3], lim[l3], m)
                if q > 1:
                    accl[l0], accl[l1], accl[l2], accl[l3] = 0.0, 0.0, 0.0, 0.0
                for i in range(m - 1, -1, -1):
                    e0 = el[i, l0] + G[i, l0] * p0
                    e1 = el[i, l1] + G[i, l1] * p1
                    e2 = el[i, l2] + G[i, l2] * p2
                    e3 = el[i, l3] + G[i, l3] * p3
                    el[i, l0], el[i, l1], el[i, l2], el[i, l3] = e0, e1, e2, e3
                    p0 *= r0
                    p1 *= r1
                    p2 *= r2
                    p3 *= r3
                    total += (e0 + e1) + (e2 + e3)
                    sq[i, l0] += e0 * e0
                    sq[i, l1] += e1 * e1
                    sq[i, l2] += e2 * e2
                    sq[i, l3] += e3 * e3
            else:
                for i in range(m):
                    e0, e1, e2, e3 = el[i, l0], el[i, l1], el[i, l2], el[i, l3]
                    total += (e0 + e1) + (e2 + e3)
                    sq[i, l0] += e0 * e0
                    sq[i, l1] += e1 * e1
                    sq[i, l2] += e2 * e2
                    sq[i, l3] += e3 * e3
        for a in range(na):  # σ̂ takes in this reading's u² (after their gain used the σ̂ before)
            f = learn[a]
            if lane[f] == IDLE:
                continue
            if kind[f] == KIND_VB:
                predict_cov(vb_P[f], h, damp[f], q_var)
            elif reading and kind[f] != KIND_IMM:
                u = own[f]
                uu = u * u
                if kind[f] == KIND_ROBUST:
                    uu = min(uu, lim[f] * lim[f]) / vb_par[f, 1]
                r_k = (k + 1) // q
                var = ad[f, AD_VAR]
                var += max(1.0 / r_k, ad[f, AD_INV_MEMORY]) * (uu - var)
                bias = 1.0 + sqqh * gain[f, 0]
                s_hat = math.sqrt(var / bias)
                if s_hat > vb_ab[f, 1]:  # held inside the σ range the filter states, the estimator's state too
                    s_hat = vb_ab[f, 1]
                    var = s_hat * s_hat * bias
                elif s_hat < vb_ab[f, 0]:
                    s_hat = vb_ab[f, 0]
                    var = s_hat * s_hat * bias
                ad[f, AD_VAR] = var
                ad[f, AD_SIGMA] = s_hat
                table_gain(table, ad, f, gain, sqqh)
                G[:, f] = gain[f]
            wsig[w, a] += ad[f, AD_SIGMA]
        pending += 1
        if pending == FLUSH:
            _flush(wsq, w, sq)
            pending = 0
        if not math.isfinite(total):  # some filter's error left the finite numbers at this step: stop it
            _bury(el, died, lane, k)
        x[m - 1] = decay * xm + shock
        if not math.isfinite(x[m - 1]):
            done = j + 1
            break
    _pour(wref, w, cvar, s_cur, same)
    _flush(wsq, w, sq)
    for f in range(nf):
        acc[f] = accl[f]
        if died[f] < 0:
            for i in range(m):
                e[f, i] = el[i, f]
    return done
