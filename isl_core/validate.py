"""Input checks for the public boundary of :mod:`isl_core`, and the one strict spelling of numbers in text.

Every public function validates its arguments here, once; kernels trust their inputs.
Messages name the argument and its allowed range, e.g. ``"sigma must be a finite number > 0, got nan"``.
No input makes a check raise anything but ``ValueError``: giant integers, nan/inf, strings, containers included.

Text (a command-line argument, a URL query value) is read by :func:`read_real` / :func:`read_int`: ASCII decimal
notation only (``20``, ``-3``, ``2.5e-1``; whole numbers of at most 15 digits), so that ``NaN``, ``Infinity``,
``1e999``, ``0x10``, Arabic-Indic or full-width digits (which Python's ``float`` would accept) and 5000-digit
integers are refused with a reason, never turned into a number or an exception of another type.
"""

from __future__ import annotations

import math
import numbers
import re
import reprlib
from typing import Any

import numpy as np

__all__ = [
    "NOT_FINITE",
    "check_int",
    "check_ints",
    "check_real",
    "check_reals",
    "check_sigma_range",
    "read_int",
    "read_real",
    "short",
]

_REAL = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d{1,4})?", re.ASCII)
_INT = re.compile(r"[+-]?\d{1,15}", re.ASCII)
_SPACE = " \t\n\r\f\v"  #: the ASCII white space around a number that is ignored (str.strip would take more)
#: the spellings of nan and ±inf that Python's ``float`` reads (lower case): refused as "not a finite number"
NOT_FINITE = frozenset({"nan", "+nan", "-nan", "inf", "+inf", "-inf", "infinity", "+infinity", "-infinity"})


def _quoted(text: str) -> str:
    return repr(text if len(text) <= 40 else text[:37] + "...")


def read_real(text: str) -> float:
    """The finite number spelled by ``text`` in ASCII decimal notation, or ``ValueError`` saying why not."""
    if not isinstance(text, str):
        raise ValueError(f"{text!r} is not text")
    t = text.strip(_SPACE)
    if not t:
        raise ValueError("the value is empty")
    if t.lower() in NOT_FINITE:
        raise ValueError(f"{_quoted(t)} is not a finite number")
    if not _REAL.fullmatch(t):
        raise ValueError(f"{_quoted(t)} is not a number (write it in ASCII digits, e.g. 20, 0.5 or 2e1)")
    x = float(t)
    if not math.isfinite(x):
        raise ValueError(f"{_quoted(t)} is too large a number")
    return x


def read_int(text: str) -> int:
    """The whole number spelled by ``text`` (ASCII digits, at most 15 of them), or ``ValueError`` saying why not."""
    if not isinstance(text, str):
        raise ValueError(f"{text!r} is not text")
    t = text.strip(_SPACE)
    if _INT.fullmatch(t):
        return int(t)
    if re.fullmatch(r"[+-]?\d+", t, re.ASCII):
        raise ValueError(f"a {len(t.lstrip('+-'))}-digit number is too long")
    x = read_real(t)  # the reason it is not a number, or …
    if not x.is_integer():
        raise ValueError(f"{_quoted(t)} is not a whole number")
    if abs(x) >= 1e15:
        raise ValueError(f"{_quoted(t)} is too large")
    return int(x)


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
        raise ValueError(f"{name} must be {rng}; {_not_a_number(value)}")
    try:
        x = float(value)
    except (OverflowError, ValueError, TypeError):  # a giant integer, an exotic Real
        raise ValueError(f"{name} must be {rng}, got {_short(value)}") from None
    bad = not math.isfinite(x)
    if lo is not None:
        bad = bad or (x <= lo if lo_open else x < lo)
    if hi is not None:
        bad = bad or (x >= hi if hi_open else x > hi)
    if bad:
        raise ValueError(f"{name} must be {rng}, got {_short(value)}")
    return x


def _digits(n: int) -> int:
    """Decimal digits of ``n`` without ``str(n)`` (which Python refuses past 4300 digits)."""
    d = max(1, int(abs(n).bit_length() * 0.30102999566398120))
    return d + int(abs(n) >= 10**d)


_REPR = reprlib.Repr()  # keyword arguments need Python 3.12
_REPR.maxlevel, _REPR.maxlist, _REPR.maxtuple, _REPR.maxdict, _REPR.maxset = 3, 6, 6, 4, 4
_REPR.maxstring, _REPR.maxother, _REPR.maxlong = 40, 40, 40


def short(value: object) -> str:
    """``repr`` of a value for a message: shortened and bounded in depth (a 5000-digit integer, a huge or a
    3000-deep list must neither flood a message nor recurse)."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_) and abs(int(value)) >= 10**40:
        return f"a {_digits(int(value))}-digit integer"
    try:
        text = _REPR.repr(value)
    except Exception:  # noqa: BLE001 — an object whose repr fails is still named by its type
        text = f"<{type(value).__name__}>"
    return text if len(text) <= 80 else text[:77] + "..."


_short = short


def _not_a_number(value: object) -> str:
    """What a value that is not a number is, in words ("got nothing (an empty box)", "got 'abc', which is text")."""
    if value is None:
        return "got nothing (an empty box or a missing value)"
    if isinstance(value, str):
        return f"got {_quoted(value)}, which is text, not a number"
    if isinstance(value, bool | np.bool_):
        return f"got {value}, a yes/no value, not a number"
    return f"got {short(value)}, a {type(value).__name__}, not a number"


def _flat(name: str, values: object, what: str, allow_empty: bool) -> list[Any]:
    """``values`` (a number or a flat sequence: list, tuple, range, 1-D array) as a list, or ``ValueError``."""
    if isinstance(values, numbers.Number) and not isinstance(values, bool | np.bool_):
        return [values]
    if isinstance(values, np.ndarray):
        if values.ndim > 1 or (values.size == 0 and not allow_empty):
            raise ValueError(f"{name} must be {what}, got an array of shape {values.shape}")
        return list(np.atleast_1d(values))
    if not isinstance(values, list | tuple | range):
        raise ValueError(f"{name} must be {what}, got {short(values)}")
    if not values and not allow_empty:
        raise ValueError(f"{name} must be {what}, got an empty sequence")
    if len(values) > 10_000:
        raise ValueError(f"{name} must be {what} (at most 10,000), got {len(values):,} values")
    return list(values)


def check_reals(
    name: str,
    values: object,
    *,
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    allow_empty: bool = False,
) -> np.ndarray:
    """A number or a flat sequence of numbers, each in range, as a float array — or ``ValueError`` naming ``name``
    (nested, ragged, empty, giant or non-numeric entries included)."""
    what = f"{'a' if allow_empty else 'a non-empty'} sequence of numbers ({_describe(lo, hi, lo_open, False)})"
    return np.array(
        [check_real(name, v, lo=lo, hi=hi, lo_open=lo_open) for v in _flat(name, values, what, allow_empty)],
        dtype=float,
    )


def check_ints(name: str, values: object, *, lo: int, hi: int | None = None) -> tuple[int, ...]:
    """A whole number or a flat non-empty sequence of them, each in range — or ``ValueError`` naming ``name``."""
    what = f"a non-empty sequence of integers >= {lo}" + (f" and <= {hi}" if hi is not None else "")
    return tuple(check_int(name, v, lo=lo, hi=hi) for v in _flat(name, values, what, False))


def check_int(name: str, value: object, *, lo: int, hi: int | None = None) -> int:
    """Return ``value`` as an int in ``[lo, hi]``, or raise ``ValueError`` naming ``name``.

    Integral floats (``3.0``) are accepted; booleans and fractional values are not.
    """
    rng = f"an integer >= {lo}" + (f" and <= {hi}" if hi is not None else "")
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be {rng}; {_not_a_number(value)}")
    if isinstance(value, numbers.Integral):
        n = int(value)
    else:
        try:
            x = float(value)
        except (OverflowError, ValueError, TypeError):
            raise ValueError(f"{name} must be {rng}, got {_short(value)}") from None
        if not (math.isfinite(x) and x.is_integer()):
            raise ValueError(f"{name} must be {rng}, got {_short(value)}")
        n = int(x)
    if n < lo or (hi is not None and n > hi):
        raise ValueError(f"{name} must be {rng}, got {_short(value)}")
    return n


def check_sigma_range(sigma_range: object) -> tuple[float, float]:
    """``(σ_min, σ_max)`` with 0 < σ_min ≤ σ_max finite, or a ``ValueError`` naming ``sigma_range``."""
    if not (isinstance(sigma_range, list | tuple | np.ndarray) and len(sigma_range) == 2):
        raise ValueError(f"sigma_range must be a pair (sigma_min, sigma_max) of numbers > 0, got {short(sigma_range)}")
    lo, hi = sigma_range
    lo = check_real("sigma_range[0]", lo, lo=0.0, lo_open=True)
    hi = check_real("sigma_range[1]", hi, lo=lo)
    return lo, hi
