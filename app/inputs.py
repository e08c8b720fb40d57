"""The dashboard's inputs: how they are declared, how a refusal is put in words, and the strict parser of a URL's text.

Every input is a ``param`` declaration, its range from the core's table of bounds (:data:`isl_core.BOUNDS`), and
param refuses a bad value when it is assigned (a ``ValueError``). Three kinds of input need more than param's own
parameters check, so they are declared with the parameters of this module, which refuse it in the same way:
:class:`Real` (a number: param's ``Number`` would take ``True`` as 1 and fail on a complex number with a
``TypeError``), :class:`Whole` (a whole number, not a boolean), :class:`Reals` (a list of numbers, each within its
own range) and :class:`Names` (distinct names from a list).

Where a value comes from outside — a widget, a link, a script's :meth:`app.state.AppState.set_inputs` — the
refusal is caught and put in words a student can act on, from the declaration alone (:func:`refusal`): it names the
input, says what is allowed and what was wrong with the value::

    σ must be a number from 0.1 to 1000; "abc" is not a number
    seed must be a whole number from 0 to 2147483647; the box is empty
    σ values must be a list of 1 to 5 numbers from 0.1 to 1000; [] is empty

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
from dataclasses import dataclass

import numpy as np
import param

from isl_core import NOT_FINITE, read_int, read_real

__all__ = ["MAX_TEXT", "Names", "Real", "Reals", "TooLong", "Whole"]
__all__ += ["allowed", "parse_text", "refusal", "shape", "show"]

MAX_TEXT = 200  #: longest query value read from a URL (the longest good one, a list of five σ, has ~40 characters)
MAX_ITEMS = 20  #: longest list read from a URL
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,40}", re.ASCII)


def _named(p: param.Parameter) -> str:
    """How a refusal names the declaration ``p``, as param's own do: "Real parameter 'AppState.sigma'"."""
    owner = p.owner if isinstance(p.owner, type) or p.owner is None else type(p.owner)
    return f"{type(p).__name__} parameter {f'{owner.__name__}.{p.name}' if owner else p.name!r}"


def _real(value: object) -> bool:
    """A real number that is not a boolean (Python counts True as 1)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


class Real(param.Number[float]):
    """A real number within its bounds: param's ``Number``, which also refuses a boolean, a callable and a complex
    number (``Number`` takes the first two, and fails on the third with a ``TypeError``)."""

    __slots__: list[str] = []

    def _validate_value(self, value, allow_None):
        if not (_real(value) or (allow_None and value is None)):
            raise ValueError(f"{_named(self)} takes a real number, not {type(value).__name__}")
        super()._validate_value(value, allow_None)


class Whole(param.Integer[int]):
    """A whole number within its bounds: param's ``Integer``, which also refuses a boolean and a callable."""

    __slots__: list[str] = []

    def _validate_value(self, value, allow_None):
        if not ((_real(value) and isinstance(value, numbers.Integral)) or (allow_None and value is None)):
            raise ValueError(f"{_named(self)} takes a whole number, not {type(value).__name__}")
        super()._validate_value(value, allow_None)


class Reals(param.List):
    """A list of numbers, as many as ``bounds`` allows, each a finite number within ``item_bounds``."""

    __slots__ = ["item_bounds"]

    def __init__(self, default=None, *, item_bounds: tuple[float, float], **params) -> None:
        self.item_bounds = item_bounds
        super().__init__(default=default, **params)
        self._validate(self.default)

    def _validate(self, val):
        super()._validate(val)
        lo, hi = self.item_bounds
        for v in val:
            if not (_real(v) and lo <= v <= hi):
                raise ValueError(f"{_named(self)} takes numbers from {lo:g} to {hi:g}, not {v!r}")


class Names(param.ListSelector):
    """Distinct names from ``objects``: param's ``ListSelector``, which also refuses a name given twice."""

    __slots__: list[str] = []

    def _validate(self, val):
        super()._validate(val)
        if val is not None and len(set(val)) != len(val):
            raise ValueError(f"{_named(self)} takes each name once, not {val!r}")


class TooLong(float):
    """A number typed in a box that the browser could only read as ±infinity: more than a float holds (beyond
    ±1.8e308, e.g. "1e400" or 5000 digits). Refused as such — not as "inf", which the user did not type."""

    def __repr__(self) -> str:
        return "a number too long for a float"


@dataclass(frozen=True)
class _Kind:
    """What a declaration allows, read from it when a value is refused or a link's text parsed (:func:`_kind`)."""

    what: str
    lo: float = -math.inf
    hi: float = math.inf
    n_min: int = 1
    n_max: int = 1
    names: tuple[str, ...] = ()

    def describe(self) -> str:
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


def _kind(p: param.Parameter) -> _Kind:
    if isinstance(p, param.Boolean):
        return _Kind("switch")
    if isinstance(p, param.Integer):
        return _Kind("whole", *p.bounds)
    if isinstance(p, param.Number):
        return _Kind("number", *p.bounds)
    if isinstance(p, param.ListSelector):
        return _Kind("names", names=tuple(p.objects))
    if isinstance(p, param.Selector):
        return _Kind("choice", names=tuple(p.objects))
    if isinstance(p, Reals):
        return _Kind("numbers", *p.item_bounds, p.bounds[0], p.bounds[1])
    raise TypeError(f"{type(p).__name__} is not a kind of input the dashboard declares")


def allowed(p: param.Parameter) -> str:
    """What the declaration ``p`` allows, in words: "a number from 0.1 to 1000"."""
    return _kind(p).describe()


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
    if isinstance(value, numbers.Integral):
        n = int(value)
        return str(n) if abs(n) < 10**40 else f"a {max(40, int(abs(n).bit_length() * 0.30103))}-digit number"
    if isinstance(value, numbers.Real):
        return f"{float(value):g}"
    if isinstance(value, list | tuple):
        inner = ", ".join(show(v) for v in list(value)[:6]) + (", …" if len(value) > 6 else "")
        return f"[{inner}]"
    return f"a {type(value).__name__} value"


def _problem(value: object, kind: _Kind) -> str:
    """Why ``value`` is not a valid ``kind`` (the part after the semicolon)."""
    if value is None or (isinstance(value, str) and not value.strip()):
        return "the box is empty"
    if kind.what == "choice":
        return f"{show(value)} is not one of them"
    if isinstance(value, str) and value.strip().lower() in NOT_FINITE:
        return f"{show(value)} is not a finite number"
    if kind.what in ("number", "whole"):
        if not _real(value):
            return f"{show(value)} is not a number"
        assert isinstance(value, numbers.Real)
        x = float(value) if not isinstance(value, numbers.Integral) or abs(int(value)) < 10**300 else math.inf
        if isinstance(value, TooLong):
            return "the number typed is too long for a float (it is beyond ±1.8e308)"
        if not math.isfinite(x):
            return f"{show(value)} is not a finite number"
        if kind.what == "whole" and not float(x).is_integer():
            return f"{show(value)} is not a whole number"
        return f"{show(value)} is {'below' if x < kind.lo else 'above'} that range"
    if kind.what == "switch" or isinstance(value, str | bytes) or not isinstance(value, list | tuple):
        return f"{show(value)} does not fit"
    if not value:
        return "[] is empty"
    if len(value) > kind.n_max:
        return f"{show(value)} has {len(value)} entries"
    if kind.what == "numbers":
        item = _Kind("number", kind.lo, kind.hi)
        return next((_problem(v, item) for v in value if not (_real(v) and kind.lo <= v <= kind.hi)), "")
    unknown = [v for v in value if not isinstance(v, str) or v not in kind.names]
    return f"{show(unknown[0])} is not one of them" if unknown else f"{show(value)} names one twice"


def refusal(p: param.Parameter, value: object, label: str | None = None) -> str:
    """Why the declaration ``p`` refused ``value``, in words naming the input (``label``, by default its own) and what
    it allows: "σ must be a number from 0.1 to 1000; 5000 is above that range"."""
    kind = _kind(p)
    return f"{p.label if label is None else label} must be {kind.describe()}; {_problem(value, kind)}"


def shape(p: param.Parameter, value: object) -> object:
    """``value`` from outside in the form the declaration ``p`` holds, without judging it (param does): a whole
    number typed in a box (``2.0``) as an int, a number as a float, a list of numbers sorted without repeats (unless
    it has more than the declaration allows: it is then refused as typed), the names of a multiple choice in the
    declaration's order. Anything else is returned as it is, for param to refuse."""
    if isinstance(p, param.Integer) and _real(value):
        assert isinstance(value, numbers.Real)
        x = float(value) if not isinstance(value, numbers.Integral) else None
        return int(value) if x is None else int(x) if math.isfinite(x) and x.is_integer() else value  # type: ignore[call-overload]
    if isinstance(p, param.Number) and _real(value):
        assert isinstance(value, numbers.Real)
        small = not isinstance(value, numbers.Integral) or abs(int(value)) < 10**300
        return float(value) if small and not isinstance(value, TooLong) else value
    if isinstance(p, Reals) and isinstance(value, list | tuple) and all(_real(v) for v in value):
        fits = len(value) <= p.bounds[1] and not any(isinstance(v, TooLong) for v in value)  # too many: as typed
        return sorted({float(v) for v in value}) if fits else value
    if isinstance(p, param.ListSelector) and isinstance(value, list | tuple):
        names = [v for v in value if isinstance(v, str)]
        known = len(names) == len(set(names)) == len(value) and set(names) <= set(p.objects)
        return [n for n in p.objects if n in names] if known else value
    return value


def parse_text(text: str, p: param.Parameter) -> object:
    """One URL query value as the Python value it spells for the declaration ``p`` (strictly; see the module
    docstring).

    Returns the value (still to be judged by the declaration when it is assigned), or raises ``ValueError`` with the
    part of the message that says what is wrong with the text.
    """
    kind = _kind(p)
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
    items = [item.strip() for item in t.split(",")] if t.strip() else []
    if len(items) > MAX_ITEMS:
        raise ValueError(f"{show(text)} has {len(items)} entries")
    if kind.what == "numbers":
        return [_parse_number(item, whole=False) for item in items]
    names = [item.strip("\"'") for item in items]
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
    return read_real(t)  # 2.5 for a whole number: read, then refused by the declaration as "not a whole number"
