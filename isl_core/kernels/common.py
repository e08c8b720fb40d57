"""What both compiled loops use: the adaptive state's columns (``AD_*``), the flush interval (:data:`FLUSH`), the
power law's root and the adaptive gain's table lookup.

The power law uses its fixed exponents: with r = |u|^{1/m}, ``|u|^{1−i/m} = r^{m−i}``, so one root a step
and filter replaces m calls to ``pow``. For m = 3 the root is :func:`fast_cbrt` (division-free, a few ulp),
m = 2, 4, 6 use ``sqrt`` and that cube root, m = 5 ``pow``.
"""

from __future__ import annotations

import math

import numpy as np

from .cache import CACHE, FASTMATH, njit

__all__ = [
    "AD_INV_MEMORY",
    "AD_INV_STEP",
    "AD_LOG_SIGMA0",
    "AD_SIGMA",
    "AD_VAR",
    "AD_WIDTH",
    "FLUSH",
    "fast_cbrt",
    "predict_cov",
    "root",
    "table_gain",
]

#: steps between flushes of the squared-error accumulator into the batch sums (see the module docstring)
FLUSH = 1024

#: columns of the per-filter adaptive state ``ad`` (nf, AD_WIDTH): table origin log σ_0, 1/(grid step),
#: 1/W (W the memory in readings; a reading is a step here), then the state carried from call to call: the
#: innovation variance v and σ̂
AD_LOG_SIGMA0, AD_INV_STEP, AD_INV_MEMORY, AD_VAR, AD_SIGMA = range(5)
AD_WIDTH = 5

#: bit pattern such that ``MAGIC − bits(a)/3`` approximates ``a^{-1/3}`` within |1 − a·y³| < 0.11
_RCBRT_MAGIC = np.uint64(0x553EE978D4FDF3B7)


@njit(cache=CACHE, nogil=True, inline="always", fastmath=FASTMATH)
def fast_cbrt(a: float) -> float:
    """Cube root of a ≥ 0 without a division (a few ulp from ``np.cbrt``).

    y ≈ a^{-1/3} from the bit pattern, then two steps of ``y ← y·(1 − e)^{-1/3}``, e = 1 − a·y³, by its
    series ``1 + e/3 + 2e²/9 + 14e³/81 + 35e⁴/243`` (error ∝ e⁵): |e| ≤ 0.11 from the bit pattern, then about 5e-6,
    then about 1e-16.
    Finally a^{1/3} = a·y². Zero, subnormal, huge, inf and nan arguments go to libm.
    """
    if not 1e-300 < a < 1e300:
        return float(np.cbrt(a))
    y = np.uint64(_RCBRT_MAGIC - np.float64(a).view(np.uint64) // np.uint64(3)).view(np.float64)
    e = 1.0 - (a * y) * (y * y)
    y = y * (1.0 + e * (1.0 / 3.0 + e * (2.0 / 9.0 + e * (14.0 / 81.0 + e * (35.0 / 243.0)))))
    e = 1.0 - (a * y) * (y * y)
    y = y * (1.0 + e * (1.0 / 3.0 + e * (2.0 / 9.0)))
    return (a * y) * y


@njit(cache=CACHE, nogil=True, inline="always", fastmath=FASTMATH)
def root(a: float, m: int) -> float:
    """``a^{1/m}`` for a ≥ 0 by the cheapest route for each m."""
    if m == 3:
        return fast_cbrt(a)
    if m == 2:
        return math.sqrt(a)
    if m == 1:
        return a
    if m == 4:
        return math.sqrt(math.sqrt(a))
    if m == 6:
        return math.sqrt(fast_cbrt(a))
    return float(a ** (1.0 / m))


@njit(cache=CACHE, nogil=True, inline="always", fastmath=FASTMATH)
def table_gain(table: np.ndarray, ad: np.ndarray, f: int, gain: np.ndarray, sqh: float) -> None:
    """``gain[f] = √h·K(σ̂)`` with log K linear in log σ̂ on the table of filter f, held at its ends."""
    nt = table.shape[1]
    t = (math.log(ad[f, AD_SIGMA]) - ad[f, AD_LOG_SIGMA0]) * ad[f, AD_INV_STEP]
    if not t > 0.0:  # below the grid (or nan: the divergence check sees it in Z)
        t = 0.0
    if t >= nt - 1:
        j = nt - 2
        w = 1.0
    else:
        j = int(t)
        w = t - j
    for i in range(table.shape[2]):
        lo = table[f, j, i]
        gain[f, i] = sqh * math.exp(lo + w * (table[f, j + 1, i] - lo))


@njit(cache=CACHE, nogil=True, fastmath=FASTMATH, inline="always")
def predict_cov(P: np.ndarray, h: float, decay: float, q_var: float) -> None:
    """P ← F_a P F_aᵀ + q_var·E Eᵀ on (X, S) in place (one mode's P): X_i += h X_{i+1}, X_m ·= decay, S += h X_1
    (the clairvoyant recursion's prediction, :func:`isl_core.kernels.clairvoyant.clairvoyant_step`, and each IMM
    mode's)."""
    a = P.shape[0]
    m = a - 1
    for c in range(a):  # rows: F_a P
        P[m, c] += h * P[0, c]
        for i in range(m - 1):
            P[i, c] += h * P[i + 1, c]
        P[m - 1, c] *= decay
    for i in range(a):  # columns: (F_a P) F_aᵀ
        P[i, m] += h * P[i, 0]
        for c in range(m - 1):
            P[i, c] += h * P[i, c + 1]
        P[i, m - 1] *= decay
    P[m - 1, m - 1] += q_var
