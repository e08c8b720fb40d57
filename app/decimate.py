"""Display decimation of long trajectories: per-bucket min/max (pure numpy).

A plot a few hundred pixels wide cannot show more than about two samples per pixel column, so a run of
N ≫ width steps is reduced before it is sent to the browser. Min/max decimation keeps, for each of ``B``
equal buckets of samples, the sample with the smallest and the one with the largest value (plus the first
and the last sample), in time order. Unlike averaging or stride sampling it preserves the envelope of the
curve exactly: every local extreme that could be seen at that resolution is drawn, and every point drawn
is a real sample.

``DISPLAY_POINTS`` ≈ 2 × a wide plot's width in pixels; a trace never has more points than that.
"""
from __future__ import annotations

import numpy as np

__all__ = ["DISPLAY_POINTS", "minmax", "minmax_indices"]

DISPLAY_POINTS = 2400  #: at most this many points per trace (≈ 2 × a 1200 px wide plot)


def minmax_indices(y: np.ndarray, max_points: int = DISPLAY_POINTS) -> np.ndarray:
    """Sorted indices of the samples of ``y`` kept by min/max decimation to at most ``max_points``.

    The first and last sample are always kept; the interior is cut into ``(max_points − 2) // 2`` buckets
    of (nearly) equal length and each contributes its arg-min and arg-max. Short inputs come back whole.
    """
    y = np.asarray(y)
    n = len(y)
    if max_points < 4:
        raise ValueError(f"max_points must be an integer >= 4, got {max_points!r}")
    if n <= max_points:
        return np.arange(n)
    buckets = (max_points - 2) // 2
    inner = y[1:-1]
    size = -(-len(inner) // buckets)  # ceil: every bucket has `size` samples but the last ...
    buckets = -(-len(inner) // size)  # ... which holds 1..size of them (padding < size)
    pad = size * buckets - len(inner)
    hi = np.concatenate([inner, np.full(pad, -np.inf)]).reshape(buckets, size)
    lo = np.concatenate([inner, np.full(pad, np.inf)]).reshape(buckets, size)
    start = np.arange(buckets) * size + 1
    keep = np.concatenate([[0], start + lo.argmin(axis=1), start + hi.argmax(axis=1), [n - 1]])
    return np.unique(keep)


def minmax(t: np.ndarray, y: np.ndarray, max_points: int = DISPLAY_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """``(t[k], y[k])`` for the indices k of :func:`minmax_indices`."""
    k = minmax_indices(y, max_points)
    return np.asarray(t)[k], np.asarray(y)[k]
