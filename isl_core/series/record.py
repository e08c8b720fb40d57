"""A recorded series: readings z_k of a signal at times t_k, validated once (:ref:`data-readings`).

The reading model: ``z_k = X₁(t_k) + η_k``, η_k independent N(0, σ_r²) — the signal's first coordinate of the model
(A.19) seen through a sensor of noise variance σ_r². Times are strictly increasing, regular or not; a missing reading
is a NaN value (the filters then only predict across it). A continuous observation ``dY = X₁ dt + σ dε`` (A.19)
averaged over an interval Δ, ``(Y(t + Δ) − Y(t))/Δ``, is such a reading of X₁'s average over the interval, with
``σ_r² = σ²/Δ``: so a series read every Δ corresponds to the model's σ = σ_r·√Δ (:func:`sigma_of_reading`), the σ of
the coarse-sensor scenario whose filters take in the increment over Δ.

Symbols: ``t`` (N,) times, ``z`` (N,) readings (NaN where missing), σ_r the reading's noise standard deviation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import numpy as np
import numpy.typing as npt

__all__ = ["MAX_READINGS", "MIN_READINGS", "Series", "series", "sigma_of_reading"]

MIN_READINGS = 10  #: fewest present readings a series may have (a fit of three parameters needs more than a few)
MAX_READINGS = 10_000_000  #: most readings a series may have (10⁷ readings of (t, z): 160 MB)


@dataclass(frozen=True)
class Series:
    """A recorded series (module docstring): times ``t`` strictly increasing, readings ``z`` (NaN = missing).

    Built by :func:`!isl_core.series.series` (which validates); ``name`` says where it came from, ``unit`` the time
    unit.
    """

    t: np.ndarray
    z: np.ndarray
    name: str = "series"
    unit: str = ""

    @property
    def n(self) -> int:
        """Number of times (readings and gaps)."""
        return len(self.t)

    @property
    def present(self) -> np.ndarray:
        """Mask (N,) of the times with a reading."""
        return cast("np.ndarray", np.isfinite(self.z))

    @property
    def spacing(self) -> float:
        """The typical interval Δ̄ between readings: the median of t_{k+1} − t_k."""
        return float(np.median(np.diff(self.t)))

    @property
    def regular(self) -> bool:
        """True when every interval equals Δ̄ to 10⁻⁹ relative."""
        d = np.diff(self.t)
        return bool(np.all(np.abs(d - self.spacing) <= 1e-9 * self.spacing))

    def head(self, n: int) -> Series:
        """The first ``n`` times (the fit part of a held-out split)."""
        return Series(self.t[:n], self.z[:n], self.name, self.unit)


def _first_bad(mask: np.ndarray) -> int:
    return int(np.flatnonzero(mask)[0])


def series(t: npt.ArrayLike, z: npt.ArrayLike, *, name: str = "series", unit: str = "") -> Series:
    """Validate times and readings into a :class:`Series` (module docstring).

    Rows are counted from 1 as in a spreadsheet, without the header. Refused, with the first offending row and the
    fix: times or readings that are not real numbers, non-finite times, times not strictly increasing, infinite
    readings, fewer than :data:`MIN_READINGS` readings present or more than :data:`MAX_READINGS` rows, readings so
    large that their squares overflow.

    Parameters
    ----------
    t, z : array_like
        Times (N,) and readings (N,) — NaN marks a missing reading.
    name, unit : str
        Where the series comes from; the unit of its times.

    Returns
    -------
    Series
        The validated series (its own float64 copies).

    Examples
    --------
    >>> from isl_core.series import series
    >>> s = series([0, 1, 2.5, 3, 4, 5, 6, 7, 8, 9, 10], [1.0, 2, float("nan"), 3, 4, 4, 5, 6, 6, 7, 8])
    >>> s.n, int(s.present.sum()), s.regular
    (11, 10, False)
    >>> series([0, 2, 1] + list(range(3, 13)), [0.0] * 13)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: times must increase strictly: row 3 has t = 1 after t = 2 in row 2 (sort the rows by time and ...
    """
    t_arr, z_arr = _as_reals("times", t), _as_reals("readings", z)
    if t_arr.shape != z_arr.shape:
        raise ValueError(f"times and readings must have the same length, got {len(t_arr)} and {len(z_arr)}")
    n = len(t_arr)
    if n > MAX_READINGS:
        raise ValueError(f"a series may have at most {MAX_READINGS} rows, got {n} (keep a part of it)")
    if not np.all(np.isfinite(t_arr)):
        row = _first_bad(~np.isfinite(t_arr))
        raise ValueError(f"times must be finite numbers: row {row + 1} has t = {t_arr[row]} (fill in or drop the row)")
    back = np.diff(t_arr) <= 0
    if back.any():
        k = _first_bad(back)
        raise ValueError(
            f"times must increase strictly: row {k + 2} has t = {t_arr[k + 1]:g} after t = {t_arr[k]:g} in row {k + 1}"
            " (sort the rows by time and remove repeated times)"
        )
    if np.isinf(z_arr).any():
        row = _first_bad(np.isinf(z_arr))
        raise ValueError(f"readings must be finite or missing: row {row + 1} has {z_arr[row]} (leave the cell empty)")
    big = np.abs(z_arr) > 1e150
    if big.any():
        row = _first_bad(big)
        raise ValueError(f"readings must be below 1e150 in size: row {row + 1} has {z_arr[row]:g} (rescale the unit)")
    gap = float(np.median(np.diff(t_arr))) if n > 1 else 1.0
    if not 1e-25 <= gap <= 1e25:
        raise ValueError(
            f"the typical interval between times must lie in [1e-25, 1e25], got {gap:g} (change the time unit)"
        )
    present = int(np.isfinite(z_arr).sum())
    if present < MIN_READINGS:
        raise ValueError(f"a series needs at least {MIN_READINGS} readings present, got {present}")
    return Series(t_arr, z_arr, str(name), str(unit))


def _as_reals(what: str, values: npt.ArrayLike) -> np.ndarray:
    try:
        arr = np.array(values, dtype=float)
    except (TypeError, ValueError, OverflowError):
        arr = None
    if arr is None or arr.ndim != 1:
        for row, v in enumerate(np.ravel(np.asarray(values, dtype=object))):
            try:
                float(v)
            except (TypeError, ValueError, OverflowError):
                cell = str(v)[:40]
                raise ValueError(f"{what} must be numbers: row {row + 1} has {cell!r} (fix or drop it)") from None
        raise ValueError(f"{what} must be a one-dimensional list of numbers")
    return arr


def sigma_of_reading(sigma_r: float, spacing: float) -> float:
    """(A.19)'s σ of a sensor read every ``spacing`` with noise sd σ_r: σ = σ_r·√Δ (module docstring)."""
    return float(sigma_r) * math.sqrt(float(spacing))
