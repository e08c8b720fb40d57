"""Presets: the papers' published experiments as sets of dashboard inputs.

Paper A, Fig. 3 (:ref:`reference-values`): m = 3, α = 0.5, w = 3 (so β = w√(2α) = 3), ν = β = 3, σ = 20 and 200,
T = 10/r_min. Paper B, Fig. 2: α = 0, m = 3, β = 3, σ = 5 and 50, and its filter (B.25–B.26) is the ISL
filter with ν = β. The white-noise model with m = 1 is the case of (B.52), where the theory gives
š/s = (π/2)^{1/4} ≈ 1.12 for ν = β; a longer horizon lets the measured ratio approach it.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType

__all__ = ["PAPER_PRESETS", "Preset"]


@dataclass(frozen=True)
class Preset:
    """A named set of input values and a one-line description of what it reproduces."""

    values: dict
    description: str


_FIG3 = {"m": 3, "alpha": 0.5, "beta_from_w": True, "w": 3.0, "nu": 3.0, "horizon": 10.0}
_PAPER_B = {"m": 3, "alpha": 0.0, "beta_from_w": False, "beta": 3.0, "nu": 3.0, "horizon": 10.0}

PAPER_PRESETS = MappingProxyType(
    {
        "Fig. 3, σ = 20": Preset({**_FIG3, "sigma": 20.0}, "Paper A, Fig. 3 (top): m = 3, α = 0.5, β = ν = 3, σ = 20."),
        "Fig. 3, σ = 200": Preset({**_FIG3, "sigma": 200.0}, "Paper A, Fig. 3 (bottom): the same with σ = 200."),
        "Paper B, Fig. 2 (α = 0, σ = 5)": Preset(
            {**_PAPER_B, "sigma": 5.0}, "Paper B, Fig. 2 (top): white-noise jerk, β = ν = 3, σ = 5."
        ),
        "Paper B, Fig. 2 (α = 0, σ = 50)": Preset(
            {**_PAPER_B, "sigma": 50.0}, "Paper B, Fig. 2 (bottom): the same with σ = 50."
        ),
        "White-noise model m = 1": Preset(
            {"m": 1, "alpha": 0.0, "beta_from_w": False, "beta": 1.0, "nu": 1.0, "sigma": 1.0, "horizon": 200.0},
            "m = 1, α = 0, ν = β: theory š/s = (π/2)^¼ ≈ 1.12 (B.52).",
        ),
    }
)
