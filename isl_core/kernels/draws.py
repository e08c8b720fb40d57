"""The noise laws of :mod:`isl_core.noise`, drawn in compiled loops from the caller's ``numpy.random.Generator``.

The scenario loop draws its noise :data:`DRAWS` steps ahead, in a tight loop of its own (:func:`draw_ahead`), in the
stream's order v_0, ε_0, v_1, ε_1, … (and the outliers' uniforms where they fall) — the order of one draw at each
step, so a run is the same bit for bit however far ahead it draws — and its time loop is left with the filters'
arithmetic (:ref:`performance-scenario`).

:func:`fill` draws ε_k alone (:meth:`isl_core.scenario.Scenario.draw_noise`), with the same arithmetic.

**A refined grid shares the coarse grid's path** (:func:`split_ahead`). A run whose step is h₀/2^L draws the base
steps' v_K and ε_K of step h₀ exactly as the run at h₀ does (same stream, same blocks of :data:`DRAWS` base steps),
then splits each into 2^L fine steps by the Brownian bridge, level by level: a standardized draw x of a step is
split into the two halves' (x + z)/√2 and (x − z)/√2, z an independent normal from the bridge's own stream of that
level. Each half is again a standard normal (for Gaussian x), the two are independent, and √(h/2)·(sum of the halves)
= √h·x: the fine run's increments of the signal's driving noise and of the observation noise, summed over each base
step, are the coarse run's, so the runs at h₀, h₀/2, h₀/4 … of one seed see one underlying path (for Student-t or
outlier noise the base step's increment keeps its law and its sum; the bridge inside it is Gaussian).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..noise import LAW_OUTLIERS, LAW_STUDENT, LAYERS
from .cache import CACHE, njit

if TYPE_CHECKING:
    import numpy as np

    from .bundles import NoiseLaw

__all__ = ["DRAWS", "draw_ahead", "fill", "split_ahead"]

DRAWS = 256  #: steps whose noise the scenario loop draws at once


@njit(cache=CACHE, nogil=True)
def _student_slow(rng: np.random.Generator, tab: np.ndarray, d: float, i: int, x: float) -> float:
    """T_d outside a layer's inner part: a draw from the tail beyond r (layer 0), or ``x`` if its wedge test passes
    (−1 if not)."""
    p = -(d + 1.0) / 2.0
    if i == 0:
        r = tab[1, 0]
        c = (d + 1.0) * r * r / (d + r * r)  # −d log f / d log x at r: the tangent Pareto envelope's exponent
        while True:
            x = r * math.exp(-math.log(1.0 - rng.random()) / (c - 1.0))
            if rng.random() < math.exp(p * (math.log1p(x * x / d) - math.log1p(r * r / d)) + c * math.log(x / r)):
                return x
    if tab[2, i] + rng.random() * (tab[3, i] - tab[2, i]) < math.exp(p * math.log1p(x * x / d)):
        return x
    return -1.0


@njit(cache=CACHE, nogil=True)
def _student_retry(rng: np.random.Generator, tab: np.ndarray, d: float, i: int, x: float, bits: int) -> float:
    """T_d after a draw ``x`` of layer ``i`` fell outside its inner part: the slow path, then new draws until one is
    accepted (each as in :func:`_draw`)."""
    while True:
        x = _student_slow(rng, tab, d, i, x)
        if x >= 0.0:
            return x if bits & 1 else -x
        y = rng.random() * (2.0 * LAYERS)
        bits = int(y)
        i = bits >> 1
        x = (y - bits) * tab[0, i]
        if x < tab[1, i]:
            return x if bits & 1 else -x


@njit(cache=CACHE, nogil=True)
def _gap(rng: np.random.Generator, p: float, cap: int) -> int:
    """Steps before the next outlier, P(G ≥ g) = (1 − p)^g: ⌊log U / log(1 − p)⌋ with U uniform on (0, 1]; at most
    ``cap`` (p = 0: ``cap``)."""
    if not p > 0.0:
        return cap
    return int(min(math.log(1.0 - rng.random()) / math.log1p(-p), float(cap)))


@njit(cache=CACHE, nogil=True)
def _draw(rng: np.random.Generator, law: NoiseLaw, vs: np.ndarray, eps: np.ndarray, count: int, with_v: bool) -> None:
    """The next ``count`` ε_k of ``law`` (:class:`~isl_core.kernels.bundles.NoiseLaw`) into ``eps``; if ``with_v``,
    each after a normal v_k into ``vs``.

    A Student-t draw: one uniform gives the layer (8 bits), the sign (1) and the position in the layer; inside the
    layer's inner part (≈ 98 % of draws) that is T_d, the rest goes to :func:`_student_retry`, out of line. One loop
    per law, written out: an inlined draw function with the retry loop in it would keep the common case out of
    registers (about twice the time a draw: :ref:`performance-scenario`)."""
    code, dof, tab, p_out, k_out, _ = law
    if code == LAW_STUDENT:
        scale = math.sqrt((dof - 2.0) / dof)  # unit variance
        for j in range(count):
            if with_v:
                vs[j] = rng.standard_normal()
            y = rng.random() * (2.0 * LAYERS)
            bits = int(y)
            i = bits >> 1
            x = (y - bits) * tab[0, i]
            if x >= tab[1, i]:
                x = _student_retry(rng, tab, dof, i, x, bits)
            elif not bits & 1:
                x = -x
            eps[j] = scale * x
        return
    # outliers: the steps between two are geometric, drawn once an outlier (not a uniform at every step); from this
    # call's first step on, afresh: the steps are independent, so the law is the same
    nxt = _gap(rng, p_out, count) if code == LAW_OUTLIERS else count
    for j in range(count):
        if with_v:
            vs[j] = rng.standard_normal()
        z = rng.standard_normal()
        if j == nxt:
            z *= k_out
            nxt += 1 + _gap(rng, p_out, count)
        eps[j] = z


@njit(cache=CACHE, nogil=True)
def draw_ahead(rng: np.random.Generator, law: NoiseLaw, vs: np.ndarray, eps: np.ndarray, count: int) -> None:
    """The next ``count`` steps' v_k (a normal) and ε_k of ``law`` (:class:`~isl_core.kernels.bundles.NoiseLaw`) into
    ``vs`` and ``eps``, drawn v_0, ε_0, v_1, ε_1, …"""
    _draw(rng, law, vs, eps, count, True)


@njit(cache=CACHE, nogil=True)
def fill(rng: np.random.Generator, law: NoiseLaw, eps: np.ndarray) -> None:
    """``eps`` filled with ε_k of ``law`` (:class:`~isl_core.kernels.bundles.NoiseLaw`) alone
    (:meth:`isl_core.scenario.Scenario.draw_noise`)."""
    _draw(rng, law, eps, eps, eps.shape[0], False)


@njit(cache=CACHE, nogil=True)
def split_ahead(
    rng: np.random.Generator,
    law: NoiseLaw,
    vbase: np.ndarray,
    ebase: np.ndarray,
    bridge: np.ndarray,
    first: int,
    count: int,
    level: int,
    vs: np.ndarray,
    eps: np.ndarray,
) -> None:
    """The next ``count`` base steps' v_K and ε_K (:func:`draw_ahead`, into ``vbase``, ``ebase``) split into 2^``level``
    fine steps each (module docstring) into ``vs`` and ``eps``; ``bridge`` (base steps, 2^level − 1, 2) the bridge's
    normals, level ℓ's 2^(ℓ−1) of a base step at 2^(ℓ−1) − 1 … 2^ℓ − 2, for v (0) and ε (1); ``first`` the row of
    this call's first base step."""
    draw_ahead(rng, law, vbase, ebase, count)
    fine = 1 << level
    half = math.sqrt(0.5)
    for K in range(count):
        row, at = first + K, K * fine
        vs[at], eps[at] = vbase[K], ebase[K]
        for lev in range(1, level + 1):
            width = 1 << (lev - 1)
            for i in range(width - 1, -1, -1):  # in place: children 2i, 2i + 1 lie at or after their parent i
                node = width - 1 + i
                x, z = vs[at + i], bridge[row, node, 0]
                vs[at + 2 * i], vs[at + 2 * i + 1] = half * (x + z), half * (x - z)
                x, z = eps[at + i], bridge[row, node, 1]
                eps[at + 2 * i], eps[at + 2 * i + 1] = half * (x + z), half * (x - z)
