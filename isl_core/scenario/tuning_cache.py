"""Tunings on disk: where they are kept (:func:`cache_dir`), what a stored tuning was computed from (its key: the
arguments, the grids and the core's sources), and storing and reading one atomically (:ref:`tuning-rule`)."""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..kernels.cache import sources_digest

if TYPE_CHECKING:
    from .base import Scenario
    from .variants import TuningGrids

__all__ = ["RULE_VERSION", "cache_dir", "cache_key", "load", "save"]

#: The tuning rule's version: raised when what a tuning means changes while its arguments do not (what a cell is, how
#: the minimax reads it). A stored tuning is keyed by it, and shipped tunings made under another one are refused
#: (:mod:`isl_core.scenario.shipped`).
RULE_VERSION = 1


def cache_dir() -> Path:
    """Where tunings are cached (module docstring): ``$ISL_CACHE_DIR``, else the user's cache directory."""
    env = os.environ.get("ISL_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "isl"


def cache_key(
    alpha: float,
    m: int,
    w: float,
    seeds: Sequence[int],
    horizon: float,
    burn: float,
    presets: Mapping[str, tuple[str, float, Scenario]],
    grids: TuningGrids,
    refine: int = 0,
) -> dict[str, Any]:
    """What a cached tuning was computed from: the rule's version, its arguments (the presets at their reading rate,
    the step's refinement), the grids and the digest of the core's sources."""
    return {
        "rule": RULE_VERSION,
        "refine": refine,
        "alpha": alpha,
        "m": m,
        "w": w,
        "seeds": list(seeds),
        "horizon": horizon,
        "burn": burn,
        "presets": {k: [s0, repr(sc)] for k, (_, s0, sc) in presets.items()},
        "grids": asdict(grids),
        "sources": sources_digest(),
    }


def save(path: Path, y: np.ndarray, seconds: float, key: dict[str, Any]) -> bool:
    """Store a tuning's statistics ``y`` under ``key`` at ``path``; False if the directory is not writable."""
    meta = {"key": key, "seconds": seconds}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path.parent, suffix=".npz", delete=False) as tmp:
            np.savez(tmp, y=y, meta=np.array(json.dumps(meta)))
        os.replace(tmp.name, path)  # atomic: a reader sees the old file or the whole new one
        return True
    except OSError:
        return False


def load(path: Path, key: dict[str, Any]) -> tuple[np.ndarray, float] | None:
    """The statistics and computing time stored at ``path`` if they were computed from ``key``, else None."""
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            if meta["key"] != json.loads(json.dumps(key)):
                return None
            return data["y"], float(meta["seconds"])
    except (OSError, KeyError, ValueError):
        return None
