"""``isl scenario``'s table as data — each row's cells at the worst coordinate, its worst seed, its tuning-seed and
held-out figures — and the rows through the presets beyond every assumed σ range, as data and as text."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ..scenario.cells import CellStats
    from ..scenario.table import ScenarioTable
    from ..scenario.tuning import Tuning

__all__ = ["beyond_data", "print_beyond", "table_rows"]


def _cell(st: CellStats, r: int, c: int) -> dict[str, Any]:
    """Row ``r``'s cell ``c`` of a table's cell statistics (the worst coordinate's ratio and interval, that
    coordinate 1-based, every coordinate's ratio, the worst seed, the seeds above 2× and those that diverged)."""
    return {
        "ratio": st.ratio[r, c],
        "low": st.low[r, c],
        "high": st.high[r, c],
        "coordinate": int(st.coordinate[r, c]) + 1,
        "coordinates": [float(v) for v in st.coordinates[r, c]],
        "worst_seed": st.worst_seed[r, c],
        "worst_seed_id": int(st.worst_seed_id[r, c]),
        "seeds_above_2x": int(st.above2[r, c]),
        "seeds_diverged": int(st.diverged[r, c]),
    }


def table_rows(res: Tuning, tab: ScenarioTable, keys: Sequence[str], ns: Mapping[str, float]) -> list[dict[str, Any]]:
    """The fair table's rows as data: each filter's tuning, origin, assumed σ range and cost, its cells (the worst
    coordinate's ratio, every coordinate's, the worst seed, the seeds above 2×), its worst per preset, and its
    tuning-seed and held-out figures."""
    rows: list[dict[str, Any]] = []
    for r, row in enumerate(tab.rows):
        cells = {k: _cell(tab.stats, r, c) for c, k in enumerate(keys)}
        presets = {}
        for p, name in enumerate(res.presets):
            worst, lo, hi = (a[r] for a in tab.preset(p))
            presets[name] = {"worst": worst, "low": lo, "high": hi}
        rows.append(
            {
                "name": row.name,
                "label": row.label,
                "role": row.role,
                "knows": row.knows,
                "assumes": row.assumes,
                "tuning": row.tuning,
                "origin": row.origin,
                "seeds": [tab.seeds[r][0], tab.seeds[r][-1]],
                "ns_per_step": ns.get(row.name),
                "cells": cells,
                "presets": presets,
                "tuning_seed_figure": {
                    "ratio": tab.tuned_figure[r],
                    "low": tab.tuned_low[r],
                    "high": tab.tuned_high[r],
                },
                "held_out_figure": tab.held_figure[r],
                "held_out_over_tuning": tab.held_figure[r] / tab.tuned_figure[r],
                "worst_seed": float(np.max(tab.stats.worst_seed[r])),
                "most_seeds_above_2x_in_a_cell": int(tab.stats.above2[r].max()),
                "flagged": bool(tab.flagged[r]),
            }
        )
    return rows


def beyond_data(tab: ScenarioTable) -> dict[str, Any]:
    """The rows (but the oracle ones) through the presets beyond every assumed σ range, as data."""
    from ..scenario.table import beyond_rows, beyond_stats

    st, held = beyond_stats(tab), tab.held
    if st is None or held is None:  # (beyond_stats is None without held)
        return {}
    names = list(held.beyond)
    keys = [f"{names[b]}:{per.name}" for b, per in held.beyond_cells]
    out: dict[str, Any] = {"scenarios": held.beyond, "seeds": [held.seeds[0], held.seeds[-1]], "rows": {}}
    for i, r in enumerate(beyond_rows(tab)):
        out["rows"][tab.rows[r].name] = {
            "assumes": tab.rows[r].assumes,
            "cells": {k: _cell(st, i, c) for c, k in enumerate(keys)},
        }
    return out


def print_beyond(tab: ScenarioTable, fmt: Callable[[float], str]) -> None:
    """The rows (but the oracle ones) through the presets beyond every assumed σ range, as text (``fmt`` formats a
    ratio)."""
    from ..scenario.table import beyond_rows, beyond_stats

    st, held = beyond_stats(tab), tab.held
    if st is None or held is None:  # (beyond_stats is None without held)
        return
    names = list(held.beyond)
    print("\nbeyond every assumed sigma range (not tuned over; report seeds), worst coordinate [interval] Xi:")
    for b, name in enumerate(names):
        cells = [c for c, (bb, _) in enumerate(held.beyond_cells) if bb == b]
        print(f"\n{name}: {held.beyond[name]}")
        print(f"  {'filter':16}" + "".join(f" | {held.beyond_cells[c][1].label[:26]:>30}" for c in cells))
        for i, r in enumerate(beyond_rows(tab)):
            print(
                f"  {tab.rows[r].name:16}"
                + "".join(
                    f" | {f'{fmt(st.ratio[i, c])} [{fmt(st.low[i, c])}, {fmt(st.high[i, c])}]':>26}"
                    f" X{st.coordinate[i, c] + 1}"
                    for c in cells
                )
                + f"   (assumes: {tab.rows[r].assumes})"
            )
