"""Tunings shipped with the package: every family's minimax knob at a grid of paper A's models, so that every model a
page reaches has tuned filters without computing a tuning (:ref:`shipped-tunings`).

``scripts/tune_grid.py`` runs :func:`isl_core.tune` at each point of a grid of α and m (w = 3, the rule's defaults)
and writes :data:`SHIPPED`: per point only each family's knob and its minimax figure — not the seeds' cells — and
what made them: the rule (:func:`rule`: its version, the arguments of :func:`isl_core.tune`, the grids, the presets)
and a **probe**, one small tuning (two seeds, a short horizon) whose cells' digest lets a test recompute it bit for
bit. A file made by another rule is refused (:func:`stale`), never used silently.

**Why a grid in α and m alone.** σ enters as absolute values (the presets' σ(0), the learners' σ ranges), so X may
not be rescaled; time may. With s = c·t, X̃_i = c^(1/2−i) X_i and Ỹ = √c·Y, paper A's model at (α, β) with σ becomes
the model at (α/c, β·c^(−m)) with the same σ, times in units of 1/r_min stay put and so do the knobs (ν/β, W readings,
c, the IMM's switch per reading). With β = w√(2α) (A.25) the tuning of (α, m, w) is that of (α·(w/3)^(1/(1/2−m)), m,
3): :func:`equivalent_alpha`. One axis of α at w = 3 covers every β. A test checks the invariance on the tuning's
statistic.

Between grid points :func:`shipped_tuning` takes the nearest in log α (at w = 3), with m exact, and says so in its
``origin``.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import json
import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..filters.base import FilterSpec
from ..model import Model
from ..requests import Execution
from ..validate import check_int, check_real
from .minimax import Tuning
from .presets import PRESETS
from .tuning import TUNING_SAMPLING, tune
from .tuning_cache import RULE_VERSION
from .variants import FAMILIES, TuningGrids, family_filter, grid_variants

__all__ = [
    "COMMAND",
    "PROBE",
    "SHIPPED",
    "W_GRID",
    "ShippedGrid",
    "ShippedTuning",
    "entry_from",
    "equivalent_alpha",
    "load_shipped",
    "probe_record",
    "probe_tuning",
    "rule",
    "shipped_json",
    "shipped_tuning",
    "stale",
    "why_not_shipped",
]

SHIPPED = Path(__file__).resolve().parent / "data" / "tunings.json"  #: the shipped grid
COMMAND = "python scripts/tune_grid.py"  #: regenerates :data:`SHIPPED` under today's rule
W_GRID = 3.0  #: every grid point's w (paper A's); other w map onto it (:func:`equivalent_alpha`)
#: the probe: one small tuning under the rule — its presets, every family, the grid's fastest ISL variant (ℓ = 4,
#: which sets h), two seeds — recomputed bit for bit by a test
PROBE: dict[str, Any] = {
    "alpha": 100.0,
    "m": 1,
    "seeds": 2,
    "horizon": 13.0,
    "grids": {"isl_ell": [-2.0, 4.0], "memory": [10.0], "robust_c": [2.0], "imm_switch": [0.001], "imm_modes": [21]},
}
_SAME = 1e-9  #: relative difference under which two α (or w) are the same point: rounding, not another model
_NOT_RULE = {"alpha", "m", "w", "presets", "sampling", "execution", "grids", "compute"}


def rule() -> dict[str, Any]:
    """Today's tuning rule, as a shipped file records it: :data:`!RULE_VERSION`, the defaults of everything of
    :func:`isl_core.tune` that shapes a tuning (its sampling's seeds — as a count, seeds 0 … n − 1 —, horizon and
    burn-in, its other arguments' defaults: the rate, the refinement), w, the families' knobs, the grids and the
    presets."""
    params = inspect.signature(tune).parameters
    grids = params["grids"].default
    sampling = TUNING_SAMPLING
    assert sampling.seeds == tuple(range(sampling.n_seeds))  # recorded as a count
    record = {
        "version": RULE_VERSION,
        "tune": {
            "seeds": sampling.n_seeds,
            "horizon": sampling.horizon,
            "burn": sampling.burn,
            **{k: p.default for k, p in params.items() if k not in _NOT_RULE},
        },
        "w": W_GRID,
        "families": {f: list(knobs) for f, (_, knobs) in FAMILIES.items()},
        "grids": asdict(grids),
        "presets": {k: [label, s0, repr(sc)] for k, (label, s0, sc) in PRESETS.items()},
    }
    out: dict[str, Any] = json.loads(json.dumps(record, default=repr))
    return out


def equivalent_alpha(alpha: float, m: int, w: float) -> float:
    """The α at w = 3 whose tuning is that of (α, m, w): α·(w/3)^(1/(1/2 − m)) (module docstring)."""
    return float(alpha * (w / W_GRID) ** (1.0 / (0.5 - m)))


@dataclass(frozen=True)
class ShippedTuning:
    """One grid point's tuning, read for a model: the point (``alpha``, ``m``, w = :data:`!W_GRID`), the model asked
    for (``asked``: α, w), per family (:data:`!isl_core.scenario.tuning.FAMILIES` order) its ``knobs`` and its minimax
    ``figures`` (ratio, low, high at 95 %, the cell) on the tuning's ``seeds``; ``origin`` says all of it in words.
    Answers as a :class:`isl_core.Tuning` does for the filters: :meth:`minimax` indexes ``knobs``."""

    alpha: float
    m: int
    asked: tuple[float, float]
    exact: bool
    knobs: tuple[dict[str, Any], ...]
    figures: tuple[tuple[float, float, float, str], ...]
    seeds: tuple[int, ...]
    grids: TuningGrids
    origin: str
    label: str

    def minimax(self, family: str) -> int:
        """The index of ``family``'s knob in ``knobs``."""
        return list(FAMILIES).index(family)

    def tuned_filters(self, model: Model) -> list[FilterSpec]:
        """Every family's filter at its shipped knob for ``model``, in :data:`!FAMILIES` order."""
        return [family_filter(f, model, k, self.grids) for f, k in zip(FAMILIES, self.knobs, strict=True)]

    def grid_filters(self, model: Model) -> list[FilterSpec]:
        """Every variant of the grids for ``model``, as :meth:`isl_core.Tuning.grid_filters`: a run beside them gets
        the tuning's step h."""
        return [family_filter(f, model, k, self.grids) for f, k in grid_variants(self.grids)]


@dataclass(frozen=True)
class ShippedGrid:
    """The shipped file: its ``rule``, the grid's ``ms``, its ``entries`` (dicts of :func:`entry_from`) and its
    ``probe`` (:func:`probe_record`)."""

    rule: dict[str, Any]
    ms: tuple[int, ...]
    entries: tuple[dict[str, Any], ...]
    probe: dict[str, Any]
    path: str

    def alphas(self, m: int) -> tuple[float, ...]:
        """The grid's α at this m (at w = 3)."""
        return tuple(sorted(e["alpha"] for e in self.entries if e["m"] == m))


@functools.cache
def load_shipped(path: str | None = None) -> ShippedGrid | None:
    """The shipped grid at ``path`` (default :data:`SHIPPED`), read once; None if there is no such file."""
    where = Path(path) if path is not None else SHIPPED
    try:
        data = json.loads(where.read_text(encoding="utf-8"))
    except OSError:  # missing or unreadable: as if not installed (said by why_not_shipped)
        return None
    entries = tuple(data["entries"])
    return ShippedGrid(
        data["rule"],
        tuple(sorted({e["m"] for e in entries})),
        entries,
        data["probe"],
        str(where),
    )


def stale(grid: ShippedGrid) -> str | None:
    """Why ``grid`` was not made by today's rule (:func:`rule`), in words, or None when it was."""
    now = rule()
    changed = [k for k in sorted(set(now) | set(grid.rule)) if now.get(k) != grid.rule.get(k)]
    if not changed:
        return None
    return (
        f"the shipped tunings ({grid.path}) were made by another tuning rule (it differs in: {', '.join(changed)}); "
        f"regenerate them with `{COMMAND}`"
    )


def _words(alphas: Iterable[float]) -> str:
    return "{" + ", ".join(f"{a:g}" for a in alphas) + "}"


def shipped_tuning(alpha: float, m: int, w: float = W_GRID, *, path: str | None = None) -> ShippedTuning | None:
    """The shipped tuning for paper A's model (α, m, w): the grid point of this m nearest in log of
    :func:`!equivalent_alpha`; None when α = 0 (no tuning), no point has this m, or the file is missing or
    :func:`!stale`."""
    alpha = check_real("alpha", alpha, lo=0.0)
    m = check_int("m", m, lo=1, hi=6)
    w = check_real("w", w, lo=0.0, lo_open=True)
    grid = load_shipped(path)
    if alpha == 0.0 or grid is None or stale(grid) is not None:
        return None
    points = [e for e in grid.entries if e["m"] == m]
    if not points:
        return None
    target = equivalent_alpha(alpha, m, w)
    entry = min(points, key=lambda e: abs(math.log(e["alpha"] / target)))
    return _shipped(grid, entry, alpha, w, target)


def why_not_shipped(alpha: float, m: int, *, path: str | None = None) -> str:
    """Why :func:`shipped_tuning` has no tuning for (α, m), in words ("" when it has one)."""
    grid = load_shipped(path)
    if alpha <= 0.0:
        return "α = 0 (paper B's model) has no tuning: the rule tunes paper A's model, β = w√(2α)"
    if grid is None:
        return f"no shipped tunings are installed ({SHIPPED}; `{COMMAND}` makes them)"
    if (reason := stale(grid)) is not None:
        return reason
    if m not in grid.ms:
        return f"the shipped tunings have no point with m = {m} (m ∈ {_words(grid.ms)})"
    return ""


def shipped_json(alpha: float, m: int, w: float = W_GRID, *, path: str | None = None) -> dict[str, Any]:
    """The shipped tuning :func:`shipped_tuning` gives (α, m, w), as JSON: its label (nearest grid point or exact),
    the point and each family's knob and minimax figure — or why there is none."""
    found = shipped_tuning(alpha, m, w, path=path)
    if found is None:
        return {"label": None, "why_none": why_not_shipped(alpha, m, path=path)}
    return {
        "label": found.label,
        "grid_point": {"alpha": found.alpha, "m": found.m, "w": W_GRID},
        "exact": found.exact,
        "origin": found.origin,
        "knobs": dict(zip(FAMILIES, found.knobs, strict=True)),
        "figures": {
            f: {"ratio": r, "low95": lo, "high95": hi, "cell": cell}
            for f, (r, lo, hi, cell) in zip(FAMILIES, found.figures, strict=True)
        },
    }


def _shipped(grid: ShippedGrid, entry: dict[str, Any], alpha: float, w: float, target: float) -> ShippedTuning:
    tune_args = grid.rule["tune"]
    grids = TuningGrids(**{k: tuple(v) for k, v in grid.rule["grids"].items()})
    point = f"α = {entry['alpha']:g}, m = {entry['m']}"
    exact = math.isclose(target, entry["alpha"], rel_tol=_SAME)
    other_w = not math.isclose(w, W_GRID, rel_tol=_SAME)  # w = β/√(2α) of β = 3√(2α) may be 3 to rounding
    yours = f"your α = {alpha:g}" + (f" with w = {w:g} is α = {target:.3g} at w = 3" if other_w else "")
    label = f"tuned at {point}"
    if not exact:
        label += f"; {yours}: nearest grid point"
    elif other_w:
        label += f"; {yours}"
    span = (
        f"shipped tuning, {label} (grid at m = {entry['m']}: α ∈ {_words(grid.alphas(entry['m']))}, w = 3; "
        f"minimax over {len(grid.rule['presets'])} presets × their periods, seeds 0–{tune_args['seeds'] - 1}, horizon "
        f"{tune_args['horizon']:g}/r_min"
        + (f", {tune_args['rate']:g} readings per 1/r_min)" if tune_args.get("rate") is not None else ")")
    )
    return ShippedTuning(
        float(entry["alpha"]),
        int(entry["m"]),
        (float(alpha), float(w)),
        exact,
        tuple(entry["knobs"][f] for f in FAMILIES),
        tuple(tuple(entry["figures"][f]) for f in FAMILIES),
        tuple(range(tune_args["seeds"])),
        grids,
        span if exact else f"{span}; Tune computes your model's own",
        label,
    )


def entry_from(tuning: Tuning) -> dict[str, Any]:
    """What the shipped file keeps of ``tuning``: its point, each family's minimax knob and figure (ratio, low, high
    at its worst cell, that cell) and its computing time."""
    ratio, low, high = tuning.stats()
    figures = {}
    for f in FAMILIES:
        j = tuning.minimax(f)
        c = int(np.argmax(np.where(np.isnan(ratio[j]), np.inf, ratio[j])))
        p, period = tuning.cells[c]
        figures[f] = [float(ratio[j, c]), float(low[j, c]), float(high[j, c]), f"{tuning.presets[p]}:{period.name}"]
    return {
        "alpha": tuning.alpha,
        "m": tuning.m,
        "w": tuning.w,
        "knobs": {f: dict(tuning.knobs[tuning.minimax(f)]) for f in FAMILIES},
        "figures": figures,
        "seconds": round(tuning.seconds, 1),
    }


def probe_tuning(workers: int | None = None) -> Tuning:
    """The probe (:data:`PROBE`) under today's rule, computed afresh (never read from a cache)."""
    p = PROBE
    grids = TuningGrids(**{k: tuple(v) for k, v in p["grids"].items()})
    tuning = tune(
        p["alpha"],
        m=p["m"],
        w=W_GRID,
        sampling=replace(TUNING_SAMPLING, seeds=tuple(range(p["seeds"])), horizon=p["horizon"]),
        execution=Execution(workers=workers, cache=False),
        grids=grids,
    )
    assert tuning is not None  # computed (compute=True)
    return tuning


def probe_record(tuning: Tuning) -> dict[str, Any]:
    """The probe as the shipped file keeps it: :data:`PROBE`, the SHA-256 of its cells (the seeds' contributions,
    bit for bit) and its knobs."""
    return {
        **PROBE,
        "cells_sha256": hashlib.sha256(np.ascontiguousarray(tuning.y).tobytes()).hexdigest(),
        "knobs": entry_from(tuning)["knobs"],
    }
