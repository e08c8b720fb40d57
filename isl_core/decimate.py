"""Decimation of long trajectories for display: per-bucket min/max (pure numpy), whole or block by block.

A plot a few hundred pixels wide cannot show more than about two samples per pixel column, so a run of
N ≫ width steps is reduced before it is sent to the browser. Min/max decimation keeps, for each of ``B``
equal buckets of samples, the sample with the smallest and the one with the largest value (plus the first
and the last sample), in time order. Unlike averaging or stride sampling it preserves the envelope of the
curve exactly: every local extreme that could be seen at that resolution is drawn, and every point drawn
is a real sample.

``DISPLAY_POINTS`` ≈ 2 × a wide plot's width in pixels; a trace never has more points than that.

:class:`MinMax` gives the same result without ever holding the whole trajectory: it takes the samples block by
block, for many traces at once (a simulation hands it each kernel chunk), and keeps O(points × traces) numbers —
so a 10⁶-step run is drawn from a few MB instead of the 336 MB its full arrays take (m = 6, six filters).
"""

from __future__ import annotations

import numpy as np

__all__ = ["DISPLAY_POINTS", "MinMax", "minmax", "minmax_indices"]

DISPLAY_POINTS = 2400  #: at most this many points per trace (≈ 2 × a 1200 px wide plot)


def _layout(n: int, max_points: int) -> tuple[int, int]:
    """``(size, buckets)`` of the interior samples 1..n−2 of ``n > max_points ≥ 4`` samples (:func:`minmax_indices`)."""
    buckets = (max_points - 2) // 2
    size = -(-(n - 2) // buckets)  # ceil: every bucket has `size` samples but the last ...
    return size, -(-(n - 2) // size)  # ... which holds 1..size of them


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
    size, buckets = _layout(n, max_points)
    inner = y[1:-1]
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


class MinMax:
    """:func:`minmax_indices` of ``T`` traces of ``n`` samples each, fed block by block (:meth:`add`).

    Blocks are consecutive rows ``Y`` (k, T) of samples 0, 1, …, n−1 in order, of any lengths. :meth:`result` gives,
    per trace, the kept sample indices and values — exactly what :func:`minmax_indices` keeps on the whole trace
    (ties: the first sample). Memory: O(buckets × T), whatever n.
    """

    def __init__(self, n: int, traces: int, max_points: int = DISPLAY_POINTS) -> None:
        if max_points < 4:
            raise ValueError(f"max_points must be an integer >= 4, got {max_points!r}")
        self.n, self.traces, self.whole = n, traces, n <= max_points
        # short: every sample is kept — as buckets of one sample each
        self.size, self.buckets = _layout(n, max_points) if not self.whole else (1, max(n - 2, 0))
        self.seen = 0
        self._ends = np.empty((2, traces))  # samples 0 and n − 1
        shape = (self.buckets, traces)
        self._lo_i, self._hi_i = np.zeros(shape, np.int64), np.zeros(shape, np.int64)
        self._lo_v, self._hi_v = np.full(shape, np.inf), np.full(shape, -np.inf)

    def add(self, Y: np.ndarray) -> None:
        """The next ``len(Y)`` samples (rows) of every trace (columns)."""
        Y = np.asarray(Y, dtype=float)
        k0, k1 = self.seen, self.seen + len(Y)
        if k1 > self.n or Y.ndim != 2 or Y.shape[1] != self.traces:
            raise ValueError(f"expected rows {k0}..{self.n - 1} of {self.traces} traces, got shape {Y.shape}")
        self.seen = k1
        if k0 == 0:
            self._ends[0] = Y[0]
        if k1 == self.n:
            self._ends[1] = Y[-1]
        lo, hi = max(k0, 1), min(k1, self.n - 1)  # the interior samples of this block
        while lo < hi:  # bucket by bucket: a partial one at each end, the full ones in between at once
            b = (lo - 1) // self.size
            end = min(1 + (b + 1) * self.size, hi)
            full = (hi - lo) // self.size if (lo - 1) % self.size == 0 else 0
            if full > 1:
                end = lo + full * self.size
                block = Y[lo - k0 : end - k0].reshape(full, self.size, self.traces)
                self._merge(slice(b, b + full), lo + np.arange(full)[:, None] * self.size, block)
            else:
                self._merge(slice(b, b + 1), np.full((1, 1), lo), Y[lo - k0 : end - k0][None])
            lo = end

    @property
    def state(self) -> tuple[np.ndarray, ...]:
        """The arrays the compiled :func:`isl_core.kernels.euler.minmax_block` folds chunks into (in place):
        ``lo_v, lo_i, hi_v, hi_i, ends`` (with :attr:`size`, its :class:`isl_core.kernels.bundles.Buckets`) — call
        :meth:`advanced` after it."""
        return self._lo_v, self._lo_i, self._hi_v, self._hi_i, self._ends

    def advanced(self, rows: int) -> None:
        """``rows`` more samples were folded in by :func:`isl_core.kernels.euler.minmax_block`."""
        self.seen += rows

    def _merge(self, rows: slice, first: np.ndarray, block: np.ndarray) -> None:
        """Fold ``block`` (buckets, samples, T) whose first samples have indices ``first`` into buckets ``rows``."""
        i_lo, i_hi = block.argmin(axis=1), block.argmax(axis=1)
        v_lo = np.take_along_axis(block, i_lo[:, None], axis=1)[:, 0]
        v_hi = np.take_along_axis(block, i_hi[:, None], axis=1)[:, 0]
        lower, higher = v_lo < self._lo_v[rows], v_hi > self._hi_v[rows]  # strict: ties keep the earlier sample
        self._lo_v[rows] = np.where(lower, v_lo, self._lo_v[rows])
        self._lo_i[rows] = np.where(lower, first + i_lo, self._lo_i[rows])
        self._hi_v[rows] = np.where(higher, v_hi, self._hi_v[rows])
        self._hi_i[rows] = np.where(higher, first + i_hi, self._hi_i[rows])

    def result(self, trace: int) -> tuple[np.ndarray, np.ndarray]:
        """``(indices, values)`` kept for ``trace``, indices increasing (after all n samples were added)."""
        if self.seen != self.n:
            raise ValueError(f"only {self.seen} of {self.n} samples were added")
        if self.n == 1:
            return np.zeros(1, np.int64), self._ends[0, trace : trace + 1].copy()
        if self.whole and np.array_equal(self._lo_i[:, trace], np.arange(1, self.n - 1)):  # every sample, in order
            return np.arange(self.n), np.concatenate(
                [self._ends[:1, trace], self._lo_v[:, trace], self._ends[1:, trace]]
            )
        idx = np.concatenate([[0], self._lo_i[:, trace], self._hi_i[:, trace], [self.n - 1]])
        val = np.concatenate(
            [[self._ends[0, trace]], self._lo_v[:, trace], self._hi_v[:, trace], [self._ends[1, trace]]]
        )
        keep, first = np.unique(idx, return_index=True)
        return keep, val[first]
