"""The clairvoyant reference's recursion, compiled: the Kalman filter of the Euler grid that knows σ_k
(:ref:`clairvoyant`).

The filter and its equations are :mod:`isl_core.scenario`'s (:func:`isl_core.scenario.clairvoyant`); here is its
recursion on the state (X, S), one step at a time (:func:`clairvoyant_step`, which the scenario loop runs in line),
and over a whole noise path (:func:`riccati_path`). :func:`clairvoyant_state` is its state at t_0.
"""

from __future__ import annotations

import numpy as np

from .bundles import ClairvoyantState
from .cache import CACHE, njit
from .common import predict_cov

__all__ = ["CYCLE_MAX", "SETTLED", "clairvoyant_state", "clairvoyant_step", "riccati_path"]

SETTLED = 1e-15  #: relative change below which the clairvoyant recursion has settled (``clairvoyant_step``)
CYCLE_MAX = 4096  #: longest sensor cycle (steps) whose settled covariance is kept: (m+1)² floats a step, ≤ 1.6 MB


@njit(cache=CACHE, nogil=True)
def clairvoyant_step(
    state: ClairvoyantState, h: float, decay: float, beta2: float, noise: float, k: int, q: int, phase: int
) -> bool:
    """Step k → k+1 of the clairvoyant recursion on the state (X, S), in place; returns whether step k is a reading.
    ``phase`` = k mod q (counted by the caller: no division per step), a reading when it is q − 1.

    ``state`` (:class:`~isl_core.kernels.bundles.ClairvoyantState`): ``P`` (m+1, m+1) the covariance of (X, S);
    ``flags`` = (R, settled, the previous step's noise, the largest change in the current sensor cycle, whether the
    noise changed in it), R the variance of the observation noise since the last reading; ``gain`` (m,) the gain of
    the latest reading (its innovation ``ΔY − h·Σ C·X̂`` times ``gain``); ``var`` (m,) the diagonal of P, at t_{k+1}
    on return; ``cycle_P`` (q, m+1, m+1) and ``cycle_R`` (q,) P and R after each step of the last sensor cycle
    (q > 1; empty otherwise: :func:`clairvoyant_state`). ``noise`` = h·σ_k²·E ε².

    F_a = I + h·A_a is bidiagonal (X_i += h·X_{i+1}, X_m ·= 1 − hα) and S += h·X_1, so P ← F_a P F_aᵀ is a pass over
    the rows and one over the columns (S's first: it reads the old X_1), without allocating. While σ_k stays, the
    recursion reaches its fixed point in floating point: with a reading at every step (q = 1) once a step changes
    no gain and no variance by more than :data:`SETTLED` relative; with q > 1 once a whole sensor cycle changes no
    gain and no variance by more than that from the cycle before, the covariance then repeating with period q. Then
    the following steps repeat it, at no cost (q > 1: the cycle's variance at this step's phase is read back), until
    σ_k changes, and the recursion goes on from the state of the step before. The scenario loop
    (:mod:`isl_core.kernels.scenario`) runs this step in line, and :func:`clairvoyant` over a whole run.
    """
    P, st, cg, cvar, cyc, cyc_r = state
    m = cg.shape[0]
    a = m + 1
    reading = phase == q - 1
    cycle = cyc.shape[0] > 0
    prev = st[2]
    st[2] = noise
    if st[1] != 0.0:
        if noise == prev:
            if cycle:  # the settled cycle's variances at this step's phase
                c = cyc[phase]
                for i in range(m):
                    cvar[i] = c[i, i]
            return reading
        st[1] = 0.0  # σ_k changed: go on from the state after the step before
        if cycle:
            back = phase - 1 if phase > 0 else q - 1
            P[:, :] = cyc[back]
            st[0] = cyc_r[back]
    st[0] += noise
    predict_cov(P, h, decay, h * beta2)
    change = 0.0
    if reading:  # the increment of Y over the last q steps: S + noise of variance R
        s = P[m, m] + st[0]
        for i in range(m):
            g = P[i, m] / s
            if k > 0:
                change = max(change, abs(g - cg[i]) / max(abs(g), 1e-300))
            cg[i] = g
        for i in range(m):
            for j in range(m):
                P[i, j] -= P[i, m] * P[j, m] / s
        for i in range(a):  # S restarts at 0, known
            P[m, i] = 0.0
            P[i, m] = 0.0
        st[0] = 0.0
    if cycle:  # against the same phase of the cycle before, then kept as this cycle's
        if phase == 0:
            st[3], st[4] = 0.0, 0.0
        c = cyc[phase]
        for i in range(m):
            change = max(change, abs(P[i, i] - c[i, i]) / P[i, i])
        c[:, :] = P
        cyc_r[phase] = st[0]
        st[3] = max(st[3], change)
        if noise != prev:
            st[4] = 1.0
        if reading and k + 1 >= 2 * q and st[3] <= SETTLED and st[4] == 0.0:
            st[1] = 1.0
    else:
        for i in range(m):
            change = max(change, abs(P[i, i] - cvar[i]) / cvar[i])
    for i in range(m):
        cvar[i] = P[i, i]
    if q == 1 and k > 0 and change <= SETTLED and noise == prev:
        st[1] = 1.0
    return reading


def clairvoyant_state(P0: np.ndarray, q: int = 1) -> ClairvoyantState:
    """The recursion's state at t_0 (:func:`clairvoyant_step`) for a reading every ``q`` steps: P on (X, S),
    (R, settled, noise, cycle change, cycle noise changed), gain, diag P, and the cycle's P and R (kept for
    1 < q ≤ :data:`CYCLE_MAX`; beyond, the recursion runs at every step)."""
    m = P0.shape[0]
    P = np.zeros((m + 1, m + 1))
    P[:m, :m] = P0
    qc = q if 1 < q <= CYCLE_MAX else 0
    return ClairvoyantState(
        P,
        np.array([0.0, 0.0, np.nan, 0.0, 0.0]),
        np.zeros(m),
        np.diagonal(P0).copy(),
        np.zeros((qc, m + 1, m + 1)),
        np.zeros(qc),
    )


@njit(cache=CACHE, nogil=True)
def riccati_path(
    state: ClairvoyantState,
    h: float,
    alpha: float,
    beta2: float,
    noise: np.ndarray,
    q: int,
    gain: np.ndarray,
    var: np.ndarray,
) -> None:
    """:func:`clairvoyant_step` from ``state`` over ``noise`` (n,): the gains of the readings (zero between) into
    ``gain`` (n, m) and diag P_k into ``var`` (n + 1, m)."""
    cg, cvar = state.gain, state.var
    decay = 1.0 - h * alpha
    var[0] = cvar
    phase = 0
    for k in range(noise.shape[0]):
        reading = clairvoyant_step(state, h, decay, beta2, noise[k], k, q, phase)
        phase = 0 if reading else phase + 1
        for i in range(cg.shape[0]):
            gain[k, i] = cg[i] if reading else 0.0
            var[k + 1, i] = cvar[i]
