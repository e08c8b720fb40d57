"""The model (A.19) between two readings, exactly (:ref:`data-discretization`).

Over an interval Δ the state moves as ``X(t + Δ) = F X(t) + w``, w ~ N(0, Q), with

    F = expm(A Δ),    Q = ∫₀^Δ expm(A s) β² E Eᵀ expm(A s)ᵀ ds

and Q by Van Loan's method (C. F. Van Loan, "Computing integrals involving the matrix exponential", IEEE Trans.
Automatic Control 23(3):395–404, 1978): ``expm([[−A, β²EEᵀ], [0, Aᵀ]] Δ) = [[·, G], [0, H]]`` gives ``F = Hᵀ`` and
``Q = F G``. A filter that propagates with A_f = A0 − a·EEᵀ (:class:`isl_core.FilterSpec`'s damping a) uses
``expm(A_f Δ)``. Intervals equal to 10⁻¹² relative share one matrix, so a regular series costs one exponential.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar, cast

import numpy as np
from scipy.linalg import expm
from threadpoolctl import threadpool_limits

from ..model import shift_matrix

_F = TypeVar("_F", bound=Callable[..., Any])

__all__ = ["ONE_THREAD", "Steps", "steps", "van_loan"]

#: a decorator: the function runs with BLAS on one thread (:func:`_expm_each`)
#: (threadpoolctl is untyped: the decorator is declared to keep the signature of the function it wraps)
ONE_THREAD = cast("Callable[[_F], _F]", threadpool_limits.wrap(limits=1, user_api="blas"))


def _drift(m: int, a: float) -> np.ndarray:
    A = shift_matrix(m)
    A[-1, -1] = -a
    return A


def _expm_each(M: np.ndarray, dt: np.ndarray) -> np.ndarray:
    """expm(M·Δ) (n, k, k) for each Δ of ``dt``, one matrix at a time (scipy's stacked expm costs more). The callers
    that repeat it (:func:`isl_core.series.fit`, :func:`isl_core.series.run_filters`) hold BLAS to one thread
    (:data:`ONE_THREAD`): a small matrix gains nothing from more, and on a busy machine their waits cost ms a call
    (:ref:`performance-data`)."""
    dt = np.asarray(dt, dtype=float)
    out = np.empty((len(dt), *M.shape))
    for j, d in enumerate(dt):
        out[j] = expm(M * d)
    return out


def van_loan(m: int, alpha: float, beta: float, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """F (n, m, m) and Q (n, m, m) of the model's α, β, m over each interval of ``dt`` (n,) (module docstring)."""
    A = _drift(m, alpha)
    blk = np.zeros((2 * m, 2 * m))
    blk[:m, :m] = -A
    blk[m - 1, 2 * m - 1] = beta * beta  # β² E Eᵀ in the upper-right block
    blk[m:, m:] = A.T
    ex = _expm_each(blk, dt)
    F = np.transpose(ex[:, m:, m:], (0, 2, 1))
    Q = F @ ex[:, :m, m:]
    return np.ascontiguousarray(F), np.ascontiguousarray(0.5 * (Q + np.transpose(Q, (0, 2, 1))))


class Steps:
    """The distinct intervals of a series and, per time k ≥ 1, which one leads to it (``index[k]``; ``index[0]`` is
    0 and unused): ``dt`` (n,), the times' intervals rounded to 10⁻¹² relative of the typical one."""

    def __init__(self, t: np.ndarray) -> None:
        d = np.diff(np.asarray(t, dtype=float))
        scale = float(np.median(d)) if len(d) else 1.0
        key = np.round(d / scale, 12)
        uniq, inv = np.unique(key, return_inverse=True)
        self.dt = uniq * scale
        self.index = np.concatenate([[0], inv]).astype(np.int64)
        #: the interval before each time (Δ_0 = the typical interval, for the first reading's normalization)
        self.before = np.concatenate([[scale], self.dt[inv]]) if len(d) else np.array([scale])

    def transition(self, m: int, a: float) -> np.ndarray:
        """expm(A_f Δ) (n, m, m) for A_f = A0 − a·EEᵀ (the filters' propagation)."""
        return _expm_each(_drift(m, a), self.dt)


def steps(t: np.ndarray) -> Steps:
    """The :class:`Steps` of times ``t``."""
    return Steps(t)
