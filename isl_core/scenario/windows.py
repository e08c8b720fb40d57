"""Where a scenario's windows and periods start, on the Euler grid, and a memory of W readings as time
(:ref:`scenario-lanes`, :ref:`memory-in-readings`)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..validate import check_real

__all__ = ["first_step", "memory_time", "window_edges", "window_times"]


def memory_time(memory: float, q: int, h: float, r_min: float) -> float:
    """W = ``memory`` readings of a sensor read every ``q`` steps of ``h``, in units of 1/``r_min``: W·q·h·r_min."""
    memory = check_real("memory (W, in sensor readings)", memory, lo=0.0)
    return memory * q * h * r_min


def window_times(horizon: float, windows: int, edges: Sequence[float] | None) -> np.ndarray:
    """The windows' edge times: ``windows`` equal windows, or ``edges`` checked (from 0 to ``horizon``, increasing)."""
    if edges is None:
        return np.linspace(0.0, horizon, windows + 1)  # more windows than steps: one a step (window_edges)
    times = np.array([check_real(f"edges[{j}]", t, lo=0.0, hi=horizon) for j, t in enumerate(edges)])
    if len(times) < 2 or times[0] != 0.0 or times[-1] != horizon or np.any(np.diff(times) <= 0.0):
        raise ValueError(f"edges must increase from 0 to the horizon {horizon:g}, got {list(edges)!r}")
    return times


def first_step(tau: float, step: float, n: int) -> int:
    """The first step k ≤ n with k·``step`` ≥ ``tau`` (``step`` = h·r_min, times in 1/r_min): where σ(t_k) takes a value
    that starts at ``tau`` (:meth:`Scenario.sigma_at`)."""
    k = min(n, max(0, math.ceil(tau / step)))
    while k > 0 and (k - 1) * step >= tau:
        k -= 1
    while k < n and k * step < tau:
        k += 1
    return k


def window_edges(times: np.ndarray, step: float, n: int) -> np.ndarray:
    """Steps (int64, increasing from 0 to n) at which windows starting at ``times`` (units of 1/r_min) start: the
    :func:`first_step` of each; a window without a step of its own is left out."""
    out = np.array([first_step(tau, step, n) for tau in times], dtype=np.int64)
    out[0], out[-1] = 0, n
    return np.unique(out)
