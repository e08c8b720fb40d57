"""The families that do not know σ(t), their knobs and the knobs' grids (:ref:`tuning-rule`): every variant a tuning
(:mod:`isl_core.scenario.tuning`) runs, by name, and paper A's own ν."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import cast

import numpy as np

from ..filters.adaptive import adaptive_kbf
from ..filters.base import SIGMA_RANGE, FilterSpec
from ..filters.imm import imm_kbf
from ..filters.isl import isl_filter, model_aware_isl
from ..filters.robust import robust_kbf
from ..filters.variational import variational_kbf
from ..model import Model

__all__ = ["FAMILIES", "TuningGrids", "family_filter", "grid_variants", "paper_nu", "variant_name"]

#: family: (its label, its knobs in order)
FAMILIES = {
    "isl": ("ISL (paper A)", ("ell",)),
    "isl_model": ("ISL model-aware", ("ell",)),
    "kbf_adaptive": ("Kalman–Bucy, adaptive σ̂", ("memory",)),
    "vb": ("variational Bayes", ("memory",)),
    "kbf_robust": ("Kalman–Bucy, adaptive σ̂, Huber", ("c", "memory")),
    "imm": ("IMM", ("switch", "modes")),
}
#: W in readings: 10 … 3000 in 15 geometric steps, and 1 … 6.7 below them, so that the minimax of the adaptive, VB
#: and robust filters (at small W) lies inside the grid, not at its edge. W = 1 is the hard limit (λ = 1: the
#: estimate is the last reading alone); variational Bayes needs W > 1 (ρ = 1 − 1/W > 0), its grid starts at 1.1
_MEMORY = (1.0, 1.1, 1.25, 1.5, 2.0, 3.0, 4.5, 6.7, *(float(f"{w:.2g}") for w in np.geomspace(10.0, 3000.0, 15)))


@dataclass(frozen=True)
class TuningGrids:
    """The knobs' grids: ν/β = 2^ℓ for ℓ in ``isl_ell`` (ISL filters); ``memory`` W in readings (adaptive, VB and
    robust filters); Huber's ``robust_c``; the IMM's ``imm_switch`` per reading and ``imm_modes`` over
    ``imm_sigma_range``.

    Examples
    --------
    >>> from isl_core import TuningGrids
    >>> TuningGrids(isl_ell=(-2.0, 0.0)).points("isl")
    [{'ell': -2.0}, {'ell': 0.0}]
    """

    isl_ell: tuple[float, ...] = tuple(np.arange(-8.0, 4.01, 0.5).tolist())
    memory: tuple[float, ...] = _MEMORY
    robust_c: tuple[float, ...] = (0.5, 0.7, 1.0, 1.345, 2.0, 3.0)
    imm_switch: tuple[float, ...] = (1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 0.3, 0.6)
    imm_modes: tuple[int, ...] = (6, 11, 16, 21, 31)
    imm_sigma_range: tuple[float, float] = (1.5, 500.0)

    def points(self, family: str) -> list[dict[str, float]]:
        """The family's grid points, each a dict knob → value."""
        if family in ("isl", "isl_model"):
            return [{"ell": float(x)} for x in self.isl_ell]
        if family == "kbf_adaptive":
            return [{"memory": float(w)} for w in self.memory]
        if family == "vb":  # W > 1: its forgetting factor ρ = 1 − 1/W must be positive
            return [{"memory": float(w)} for w in self.memory if w > 1.0]
        if family == "kbf_robust":
            return [{"c": float(c), "memory": float(w)} for c in self.robust_c for w in self.memory]
        return [{"switch": float(p), "modes": int(j)} for p in self.imm_switch for j in self.imm_modes]


def family_filter(
    family: str, model: Model, knob: Mapping[str, float], grids: TuningGrids = TuningGrids()
) -> FilterSpec:
    """The filter of ``family`` at ``knob`` for ``model``'s α, β, m (σ is not used; the σ-learners over
    :data:`SIGMA_RANGE` from its geometric middle), named ``family`` and labelled with its knob."""
    guess = math.sqrt(SIGMA_RANGE[0] * SIGMA_RANGE[1])
    if family in ("isl", "isl_model"):
        nu = model.beta * 2.0 ** knob["ell"]
        spec = isl_filter(model, nu) if family == "isl" else model_aware_isl(model, nu)
        lab = f"{FAMILIES[family][0]} (ν/β = 2^{knob['ell']:g} = {2.0 ** knob['ell']:.3g}, ν = {nu:.3g})"
        return FilterSpec(family, lab, spec.damp, spec.coef, spec.power)
    if family == "kbf_adaptive":
        return adaptive_kbf(model, sigma_range=SIGMA_RANGE, memory=knob["memory"], sigma_init=guess)
    if family == "vb":
        return variational_kbf(model, sigma_init=guess, memory=knob["memory"])
    if family == "kbf_robust":
        return robust_kbf(model, c=knob["c"], sigma_range=SIGMA_RANGE, memory=knob["memory"], sigma_init=guess)
    if family == "imm":
        return imm_kbf(model, sigma_range=grids.imm_sigma_range, modes=cast(int, knob["modes"]), switch=knob["switch"])
    raise ValueError(f"family must be one of {', '.join(FAMILIES)}; got {family!r}")


def grid_variants(grids: TuningGrids) -> list[tuple[str, dict[str, float]]]:
    """Every (family, knob) of the grids, in :data:`FAMILIES` order: the variants a tuning runs."""
    return [(f, knob) for f in FAMILIES for knob in grids.points(f)]


def variant_name(family: str, knob: Mapping[str, float]) -> str:
    """A variant's stable name: ``vb@memory=30``, ``imm@switch=0.01,modes=11``."""
    return f"{family}@" + ",".join(f"{k}={v:g}" for k, v in knob.items())


def paper_nu(model: Model, alpha: float, m: int, w: float) -> tuple[float, str]:
    """Paper A's ν for ``model``: β times table (A.31)'s ν/β at (``alpha``, ``m``, ``w``), or β where the table has
    none; and a line that says which."""
    from ..paper import a31_nu_over_beta

    nob = a31_nu_over_beta(alpha, m, w)
    if nob is None:
        return model.beta, f"ISL at ν = β = {model.beta:.3g} (table (A.31) has no ν for α = {alpha:g})"
    return model.beta * nob, f"ISL at table (A.31)'s ν/β = {nob:g} (ν = {model.beta * nob:.3g}; the paper's value)"
