"""Checks of the dashboard's inputs, in human words, and the strict parser of their spellings in a URL.

Every value that reaches an input — from a widget, a link, a script — goes through :func:`clean` with the input's
declared kind and range, and comes back as a clean value or a ``ValueError`` whose message a student can act on:
it names the input (its label and its name in links), says what is allowed, and what was wrong with the value::

    σ (sigma) must be a number from 0.1 to 1000; "abc" is not a number
    seed must be a whole number from 0 to 2147483647; the box is empty
    σ values (sweep_sigmas) must be a list of 1 to 5 numbers from 0.1 to 1000; [] is empty

A URL carries text: :func:`parse_text` turns one query value into a Python value *without* ``json`` or ``eval`` —
numbers only in ASCII decimal notation (``20``, ``2e1``, ``-3``), whole numbers of at most 15 digits, flat lists of
at most 20 items, at most :data:`MAX_TEXT` characters — so no spelling can recurse, allocate a giant integer or
smuggle in nan/inf: ``[[[[…``, a 5000-digit seed, ``NaN``, ``Infinity``, Arabic-Indic digits are all refused with
a message, never an exception. Numbers are spelled as everywhere in the project (:func:`isl_core.validate.read_real`).
"""

from __future__ import annotations

import math
import numbers
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from isl_core import NOT_FINITE, read_int, read_real

__all__ = ["MAX_TEXT", "Kind", "TooLong", "clean", "clean_declared", "kind_of", "kinds_of", "parse_text", "show"]

MAX_TEXT = 200  #: longest query value read from a URL (the longest good one, a list of five σ, has ~40 characters)
MAX_ITEMS = 20  #: longest list read from a URL
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,40}", re.ASCII)


class TooLong(float):
    """A number typed in a box that the browser could only read as ±infinity: more than a float holds (beyond
    ±1.8e308, e.g. "1e400" or 5000 digits). Refused as such — not as "inf", which the user did not type."""

    def __repr__(self) -> str:
        return "a number too long for a float"


@dataclass(frozen=True)
class Kind:
    """An input's kind and range: ``"number"``, ``"whole"``, ``"switch"``, ``"numbers"`` (a list of 1..``n_max``
    numbers in [lo, hi]), ``"names"`` (a list of distinct names from ``names``) or ``"choice"`` (one of ``names``)."""

    what: str
    lo: float = -math.inf
    hi: float = math.inf
    n_min: int = 1
    n_max: int = 1
    names: tuple[str, ...] = ()

    def describe(self) -> str:
        """What is allowed, in words: "a number from 0.1 to 1000"."""
        span = f"from {_plain(self.lo)} to {_plain(self.hi)}"
        if self.what == "number":
            return f"a number {span}"
        if self.what == "whole":
            return f"a whole number {span}"
        if self.what == "switch":
            return "on or off (true or false)"
        if self.what == "numbers":
            return f"a list of {self.n_min} to {self.n_max} numbers {span}"
        if self.what == "choice":
            return f"one of {', '.join(self.names)}"
        return f"a list of distinct names from {', '.join(self.names)}"


def _plain(x: float) -> str:
    """A bound as people write it: whole numbers in full (2147483647), others with 6 significant digits."""
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"


def show(value: object) -> str:
    """A value as a user would recognise it: text in quotes and shortened, numbers plainly, lists in brackets."""
    if isinstance(value, str):
        text = value if len(value) <= 40 else value[:37] + "…"
        return f'"{text}"'
    if isinstance(value, TooLong):
        return repr(value)
    if isinstance(value, bool | np.bool_):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        n = int(value)
        return str(n) if abs(n) < 10**40 else f"a {max(40, int(abs(n).bit_length() * 0.30103))}-digit number"
    if isinstance(value, numbers.Real):
        return f"{float(value):g}"
    if isinstance(value, list | tuple):
        inner = ", ".join(show(v) for v in list(value)[:6]) + (", …" if len(value) > 6 else "")
        return f"[{inner}]"
    return f"a {type(value).__name__} value"


def _problem(value: object, kind: Kind) -> str:
    """Why ``value`` is not a valid ``kind`` (the part after the semicolon)."""
    if value is None or (isinstance(value, str) and not value.strip()):
        return "the box is empty"
    if kind.what == "choice":
        return f"{show(value)} is not one of them"
    if isinstance(value, str) and value.strip().lower() in NOT_FINITE:
        return f"{show(value)} is not a finite number"
    if kind.what in ("number", "whole"):
        if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
            return f"{show(value)} is not a number"
        x = float(value) if not isinstance(value, numbers.Integral) or abs(int(value)) < 10**300 else math.inf
        if isinstance(value, TooLong):
            return "the number typed is too long for a float (it is beyond ±1.8e308)"
        if not math.isfinite(x):
            return f"{show(value)} is not a finite number"
        if kind.what == "whole" and not float(x).is_integer():
            return f"{show(value)} is not a whole number"
        return f"{show(value)} is {'below' if x < kind.lo else 'above'} that range"
    return f"{show(value)} does not fit"


def _number(value: object, kind: Kind) -> float | None:
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        return None
    if isinstance(value, numbers.Integral):
        if abs(int(value)) > 10**300:
            return None
        value = int(value)
    x = float(value)
    return x if math.isfinite(x) and kind.lo <= x <= kind.hi else None


def clean(label: str, value: object, kind: Kind) -> object:
    """``value`` checked against ``kind``: the clean value, or a ``ValueError`` in words naming ``label``."""
    what = kind.what
    if what == "number":
        x = _number(value, kind)
        if x is not None:
            return x
    elif what == "whole":
        x = _number(value, kind)
        if x is not None and x.is_integer():
            return int(x)
    elif what == "switch":
        if isinstance(value, bool | np.bool_):
            return bool(value)
    elif what == "numbers":
        return _clean_numbers(label, value, kind)
    elif what == "choice":
        if isinstance(value, str) and value in kind.names:
            return value
    else:
        return _clean_names(label, value, kind)
    raise ValueError(f"{label} must be {kind.describe()}; {_problem(value, kind)}")


def _clean_numbers(label: str, value: object, kind: Kind) -> list[float]:
    base = f"{label} must be {kind.describe()}"
    if isinstance(value, str | bytes) or not isinstance(value, list | tuple):
        raise ValueError(f"{base}; {_problem(value, kind)}")
    if not value:
        raise ValueError(f"{base}; [] is empty")
    if len(value) > kind.n_max:
        raise ValueError(f"{base}; {show(value)} has {len(value)} entries")
    item = Kind("number", kind.lo, kind.hi)
    out = set()
    for v in value:
        x = _number(v, item)
        if x is None:
            raise ValueError(f"{base}; {_problem(v, item)}")
        out.add(x)
    return sorted(out)


def _clean_names(label: str, value: object, kind: Kind) -> list[str]:
    base = f"{label} must be {kind.describe()}"
    if isinstance(value, str | bytes) or not isinstance(value, list | tuple):
        raise ValueError(f"{base}; {_problem(value, kind)}")
    for v in value:
        if not isinstance(v, str) or v not in kind.names:
            raise ValueError(f"{base}; {show(v)} is not one of them")
    if len(set(value)) != len(value):
        raise ValueError(f"{base}; {show(value)} names one twice")
    return [n for n in kind.names if n in value]


def parse_text(text: str, kind: Kind) -> object:
    """One URL query value as the Python value it spells for ``kind`` (strictly; see the module docstring).

    Returns the value (still to be range-checked by :func:`clean`), or raises ``ValueError`` with the part of the
    message that says what is wrong with the text.
    """
    if len(text) > MAX_TEXT:
        raise ValueError(f"the value in the link is {len(text):,} characters long")
    t = text.strip()
    if kind.what in ("number", "whole"):
        return _parse_number(t, whole=kind.what == "whole")
    if kind.what == "choice":
        t = t.strip("\"'")
        if not _NAME.fullmatch(t):
            raise ValueError(f"{show(text)} is not a name")
        return t
    if kind.what == "switch":
        word = t.lower()
        if word in ("true", "1", "on", "yes"):
            return True
        if word in ("false", "0", "off", "no"):
            return False
        raise ValueError(f"{show(text)} is neither true nor false")
    if t.startswith("[") and t.endswith("]"):
        t = t[1:-1]
    if "[" in t or "]" in t or "{" in t:
        raise ValueError(f"{show(text)} is not a flat list")
    items = [p.strip() for p in t.split(",")] if t.strip() else []
    if len(items) > MAX_ITEMS:
        raise ValueError(f"{show(text)} has {len(items)} entries")
    if kind.what == "numbers":
        return [_parse_number(p, whole=False) for p in items]
    names = [p.strip("\"'") for p in items]
    for name in names:
        if not _NAME.fullmatch(name):
            raise ValueError(f"{show(name)} is not a name")
    return names


def _parse_number(t: str, *, whole: bool) -> float | int:
    if whole:
        try:
            return read_int(t)
        except ValueError as exc:
            if "not a whole number" not in str(exc):
                raise
    return read_real(t)  # 2.5 for a whole number: read, then refused by clean() as "not a whole number"


def kind_of(p, item_bounds: tuple[float, float] | None = None) -> Kind:
    """The :class:`Kind` of an input from its declaration ``p`` (a param.Parameter with bounds); a list of numbers
    takes the range of its entries from ``item_bounds``."""
    import param  # the inputs are declared with param; this module itself needs only numpy

    if isinstance(p, param.Boolean):
        return Kind("switch")
    if isinstance(p, param.Integer):
        return Kind("whole", *p.bounds)
    if isinstance(p, param.Number):
        return Kind("number", *p.bounds)
    if isinstance(p, param.ListSelector):
        return Kind("names", names=tuple(p.objects))
    if isinstance(p, param.Selector):
        return Kind("choice", names=tuple(p.objects))
    if item_bounds is None:
        raise ValueError(f"the list input {p.name} needs the range of its entries")
    return Kind("numbers", *item_bounds, p.bounds[0], p.bounds[1])


def kinds_of(names: Sequence[str], params, item_bounds: dict[str, tuple[float, float]]) -> dict[str, Kind]:
    """The :class:`Kind` of each input of ``names`` from its declaration in ``params`` (:func:`kind_of`)."""
    return {name: kind_of(params[name], item_bounds.get(name)) for name in names}


def clean_declared(p, value: object) -> object:
    """``value`` checked against the declaration ``p`` of its input (a param.Parameter), named by its label: the
    clean value or a ``ValueError`` in words (:func:`clean`)."""
    return clean(p.label, value, kind_of(p))
