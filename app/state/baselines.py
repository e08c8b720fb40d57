"""The extra filters' room: which baselines ride on the run, σ̄ of the mismatched filter, the plausible σ range.

The filters themselves and their theory are in :mod:`app.extras`; the run that draws them is the session's
(:class:`app.state.AppState`), which watches this room's inputs.
"""

from __future__ import annotations

from typing import ClassVar

from isl_core.filters.baselines import LABELS

from ..extras import EXTRA_NAMES, SIGMA_BOUNDS, SIGMA_DESIGN, SIGMA_RANGE
from ..inputs import Names, Real
from .room import Room

__all__ = ["BaselinesRoom"]


class BaselinesRoom(Room):
    """Inputs of the extra filters drawn on the run (the module docstring); keys as their names."""

    KEYS: ClassVar[dict[str, str]] = {
        "extra_filters": "extra_filters",
        "sigma_design": "sigma_design",
        "sigma_min": "sigma_min",
        "sigma_max": "sigma_max",
    }

    extra_filters = Names(
        default=[],
        objects=list(EXTRA_NAMES),
        label="extra filters",
        doc=("Baselines drawn on the same run (same noise): " + ", ".join(LABELS[n] for n in EXTRA_NAMES) + "."),
    )
    sigma_design = Real(
        SIGMA_DESIGN,
        bounds=SIGMA_BOUNDS,
        label="σ̄ of the KBF for mid σ",
        doc=("The σ the mismatched Kalman–Bucy filter is designed for (its gain solves the CARE, A.23, at σ̄)."),
    )
    sigma_min = Real(
        SIGMA_RANGE[0],
        bounds=SIGMA_BOUNDS,
        label="σ min",
        doc=("Bottom of the plausible σ range (below σ max): the adaptive filter's table, the worst-case table."),
    )
    sigma_max = Real(
        SIGMA_RANGE[1],
        bounds=SIGMA_BOUNDS,
        label="σ max",
        doc=("Top of the plausible σ range (above σ min): the minimax Kalman–Bucy filter is designed for it."),
    )

    @property
    def sigma_range(self) -> tuple[float, float]:
        """[σ min, σ max]."""
        return self.sigma_min, self.sigma_max
