"""What the tuning part of the Scenario tab says when the picture's knobs come from a shipped tuning
(:func:`isl_core.shipped_tuning`): the grid point, how near the page's model it is, each family's knob and
its minimax figure on the tuning's seeds — no curves, which only a tuning computed for the model has."""

from __future__ import annotations

import html

from isl_core import ShippedTuning
from isl_core.scenario.table import knob_text
from isl_core.scenario.tuning import FAMILIES

from ..text import R_MIN, powers

__all__ = ["shipped_note"]


def shipped_note(shipped: ShippedTuning) -> str:
    """Markdown: the shipped tuning's point and every family's knob with its minimax figure (ratio [95 %], cell)."""
    knobs = "; ".join(
        f"{html.escape(label)}: {powers(knob_text(knob))} (largest ratio {ratio:.3g} [{low:.3g}, {high:.3g}], "
        f"{html.escape(cell)})"
        for (label, _), knob, (ratio, low, high, cell) in zip(
            FAMILIES.values(), shipped.knobs, shipped.figures, strict=True
        )
    )
    return (
        f"**{html.escape(shipped.label)}** — the knobs shipped with the package (simulated on the tuning's seeds "
        f"{shipped.seeds[0]}–{shipped.seeds[-1]}): {knobs}. **Tune** computes this model's own tuning and draws its "
        f"curves (minutes on two cores, then kept). Tuning: {html.escape(shipped.origin.replace('r_min', R_MIN))}."
    )
