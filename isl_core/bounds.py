"""The one table of the model's and the run's bounds: σ, α, β, w, ν, m, the horizon and the seed.

Each quantity is written here once, with two ranges:

* its *domain*, what the core accepts (σ any finite number > 0, m a whole number 1 … :data:`M_MAX`): the core's
  constructors check it (:meth:`Bound.real`, :meth:`Bound.whole`, e.g. in :class:`isl_core.Model`), and the message
  of a refusal names the argument and this domain (``"sigma must be a finite number > 0, got nan"``);
* its *range*, the part of the domain the dashboard offers (σ from 0.1 to 1000): its inputs are declared with it
  (``param.Number(bounds=BOUNDS.sigma.range)``), so that a page, a link and the core never disagree on a bound.

The range is inside the domain, a test checks it. Quantities of one job only (a sweep's batches, a filter's memory)
keep their checks where they are used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .validate import check_int, check_ints, check_real, check_reals

__all__ = ["BOUNDS", "M_MAX", "SEED_MAX", "Bound", "Bounds"]

M_MAX = 6  #: the largest state dimension supported (the kernels and the dashboard are sized for it)
SEED_MAX = 2**31 - 1  #: the largest seed the dashboard offers (a link's seed fits a 32-bit signed integer)


@dataclass(frozen=True)
class Bound:
    """One quantity's bounds (the module docstring).

    ``name`` is its argument's name in the core and its key in the dashboard's links; ``kind`` ``"real"`` or
    ``"int"``; the domain ``lo`` (excluded when ``lo_open``) to ``hi`` (None: no upper bound); ``range`` the
    dashboard's ``(low, high)``, both included; ``unit`` in words ("" for a pure number); ``doc`` the one sentence
    that says what the quantity is, where the dashboard explains its input.
    """

    name: str
    symbol: str
    kind: str
    lo: float
    lo_open: bool
    hi: float | None
    range: tuple[float, float]
    unit: str
    doc: str

    def real(self, value: object, name: str | None = None) -> float:
        """``value`` within the domain of this real quantity, as a float, or ``ValueError`` naming ``name`` (default
        the quantity's name) and the domain."""
        self._kind("real")
        return check_real(self.name if name is None else name, value, lo=self.lo, hi=self.hi, lo_open=self.lo_open)

    def whole(self, value: object, name: str | None = None) -> int:
        """``value`` within the domain of this whole quantity, as an int, or ``ValueError`` naming ``name`` (default
        the quantity's name) and the domain."""
        self._kind("int")
        hi = None if self.hi is None else int(self.hi)
        return check_int(self.name if name is None else name, value, lo=int(self.lo), hi=hi)

    def reals(self, values: object, name: str) -> np.ndarray:
        """A number or a flat non-empty sequence of them, each within the domain, as a float array, or ``ValueError``
        naming ``name``."""
        self._kind("real")
        return check_reals(name, values, lo=self.lo, hi=self.hi, lo_open=self.lo_open)

    def wholes(self, values: object, name: str) -> tuple[int, ...]:
        """A whole number or a flat non-empty sequence of them, each within the domain, or ``ValueError`` naming
        ``name``."""
        self._kind("int")
        return check_ints(name, values, lo=int(self.lo), hi=None if self.hi is None else int(self.hi))

    def _kind(self, kind: str) -> None:
        if self.kind != kind:
            raise TypeError(f"{self.name} is of kind {self.kind!r}, not {kind!r}")

    def contains(self, low: float, high: float) -> bool:
        """Whether ``[low, high]`` lies within the domain."""
        above = low > self.lo if self.lo_open else low >= self.lo
        return above and low <= high and (self.hi is None or high <= self.hi) and math.isfinite(high)


@dataclass(frozen=True)
class Bounds:
    """The table: one :class:`Bound` per quantity, by attribute (``BOUNDS.sigma``) or by name (``BOUNDS["sigma"]``)."""

    alpha: Bound
    beta: Bound
    w: Bound
    sigma: Bound
    nu: Bound
    m: Bound
    horizon: Bound
    seed: Bound

    def __getitem__(self, name: str) -> Bound:
        if name not in self.__dataclass_fields__:
            raise KeyError(f"no bounds for {name!r}; the table holds {', '.join(self.names())}")
        bound: Bound = getattr(self, name)
        return bound

    def names(self) -> tuple[str, ...]:
        """The quantities of the table, in its order."""
        return tuple(self.__dataclass_fields__)


_INF = None

#: the model's and the run's bounds (the module docstring)
BOUNDS = Bounds(
    alpha=Bound(
        "alpha",
        "α",
        "real",
        0.0,
        False,
        _INF,
        (0.0, 100.0),
        "1/time",
        "Damping of the top derivative Xₘ, dXₘ = −α Xₘ dt + β dv (A.5); α = 0 is paper B's white-noise model.",
    ),
    beta=Bound(
        "beta",
        "β",
        "real",
        0.0,
        True,
        _INF,
        (0.01, 1000.0),
        "",
        "Intensity of the noise driving Xₘ (A.5); used when 'β from w' is off.",
    ),
    w=Bound(
        "w",
        "w",
        "real",
        0.0,
        True,
        _INF,
        (0.01, 100.0),
        "",
        "Stationary standard deviation of Xₘ (A.25); used when 'β from w' is on. Paper A: w = 3.",
    ),
    sigma=Bound(
        "sigma",
        "σ",
        "real",
        0.0,
        True,
        _INF,
        (0.1, 1000.0),
        "",
        "Observation noise intensity, dY = X₁ dt + σ dε (A.6). Known to the Kalman–Bucy filter only.",
    ),
    nu=Bound(
        "nu",
        "ν",
        "real",
        0.0,
        True,
        _INF,
        (0.001, 10000.0),
        "",
        "The ISL filter's only tuning knob (A.17); paper A studies ν/β = 2^ℓ, ℓ = −8..2.",
    ),
    m=Bound("m", "m", "int", 1, False, M_MAX, (1, M_MAX), "", "State dimension: X₁ and its m − 1 derivatives (A.1)."),
    horizon=Bound(
        "horizon",
        "horizon",
        "real",
        0.0,
        True,
        _INF,
        (1.0, 1000.0),
        "settling times 1/r_min",
        "Simulated time T in units of the optimal filter's settling time 1/r_min (A.24); paper A, Fig. 3: 10.",
    ),
    seed=Bound("seed", "seed", "int", 0, False, _INF, (0, SEED_MAX), "", "Seed of the noise: same seed, same run."),
)
