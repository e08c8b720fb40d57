"""Input checks for the public boundary of :mod:`isl_core`.

Every public function validates its arguments here, once; kernels trust their inputs.
Messages name the argument and its allowed range, e.g. ``"sigma must be a finite number > 0, got nan"``.
"""
from __future__ import annotations

import math
import numbers

__all__ = ["check_int", "check_real"]


def _describe(lo: float | None, hi: float | None, lo_open: bool, hi_open: bool) -> str:
    parts = []
    if lo is not None:
        parts.append(f"{'>' if lo_open else '>='} {lo:g}")
    if hi is not None:
        parts.append(f"{'<' if hi_open else '<='} {hi:g}")
    return "a finite number" + (" " + " and ".join(parts) if parts else "")


def check_real(
    name: str,
    value: object,
    *,
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    hi_open: bool = False,
) -> float:
    """Return ``value`` as a float, or raise ``ValueError`` naming ``name`` and its range.

    Booleans, strings, ``None``, complex numbers, nan and inf are all rejected.
    """
    rng = _describe(lo, hi, lo_open, hi_open)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be {rng}, got {value!r} of type {type(value).__name__}")
    x = float(value)
    bad = not math.isfinite(x)
    if lo is not None:
        bad = bad or (x <= lo if lo_open else x < lo)
    if hi is not None:
        bad = bad or (x >= hi if hi_open else x > hi)
    if bad:
        raise ValueError(f"{name} must be {rng}, got {value!r}")
    return x


def check_int(name: str, value: object, *, lo: int, hi: int | None = None) -> int:
    """Return ``value`` as an int in ``[lo, hi]``, or raise ``ValueError`` naming ``name``.

    Integral floats (``3.0``) are accepted; booleans and fractional values are not.
    """
    rng = f"an integer >= {lo}" + (f" and <= {hi}" if hi is not None else "")
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be {rng}, got {value!r} of type {type(value).__name__}")
    if isinstance(value, numbers.Integral):
        n = int(value)
    else:
        x = float(value)
        if not (math.isfinite(x) and x.is_integer()):
            raise ValueError(f"{name} must be {rng}, got {value!r}")
        n = int(x)
    if n < lo or (hi is not None and n > hi):
        raise ValueError(f"{name} must be {rng}, got {value!r}")
    return n
