"""Verdicts out of sample: the tuned filters run again on seeds the tuning never saw.

A tuning (:func:`isl_core.tune`) picks each family's knob on its seeds 0 … S − 1; a figure read on
those same seeds is the minimum of a noisy curve, biased downwards, and blind to a learner that runs away on a seed
it did not see. :func:`held_out` runs the table's filters — the two references, paper A's ISL filter and every
family at its minimax knob — on **report seeds** disjoint from the tuning's (by default the 4·S seeds that follow
them), on the tuning's grid (so that each run is, seed by seed, the run the tuning would have made), and keeps the
seeds' contributions per coordinate (:func:`isl_core.scenario.periods.per_seed`). The fair table
(:func:`isl_core.scenario.table.table_from`) reads its cells from them and compares each tuned row's worst cell with
its tuning-seed figure. The same filters also run through ``beyond`` — by default
:data:`isl_core.scenario.presets.BEYOND`, σ outside every range a filter assumes, never tuned over. Like a tuning it is
reproducible bit for bit and cached on disk (:mod:`.tuning_cache`).
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..requests import Execution
from ..validate import check_int
from .base import Scenario
from .minimax import Tuning
from .periods import Period, scenario_periods
from .presets import BEYOND, at_rate
from .tasks import local_threads, plan_preset, run_cells
from .tuning_cache import cache_dir, cache_key, load, save
from .variants import FAMILIES

__all__ = ["HeldOut", "held_out", "report_columns"]

REPORT_FACTOR = 4  #: report seeds per tuning seed by default


@dataclass(frozen=True)
class HeldOut:
    """The table's filters on the report ``seeds``: ``columns`` their indices among the tuning's filters, ``y``
    (seeds, cells, columns, m) the seeds' contributions per coordinate; the same over the presets ``beyond`` (name →
    label) in ``beyond_y`` (seeds, ``beyond_cells``, columns, m), cells (index in ``beyond``, period); ``origin``
    says where it came from."""

    seeds: tuple[int, ...]
    columns: tuple[int, ...]
    y: np.ndarray
    seconds: float
    origin: str
    beyond: dict[str, str]
    beyond_cells: tuple[tuple[int, Period], ...]
    beyond_y: np.ndarray


def report_columns(tuning: Tuning) -> tuple[int, ...]:
    """The tuning's filters the table reports: the clairvoyant and σ(0) references, paper A's ISL filter and every
    family's minimax variant (:data:`isl_core.FAMILIES` order; a variant once)."""
    cols = [0, 1, 2]
    for family in FAMILIES:
        j = tuning.minimax(family)
        if j not in cols:
            cols.append(j)
    return tuple(cols)


def held_out(
    tuning: Tuning,
    n_seeds: int | None = None,
    *,
    execution: Execution | None = None,
    beyond: Mapping[str, tuple[str, float, Scenario]] = BEYOND,
    compute: bool = True,
) -> HeldOut | None:
    """The table's filters (:func:`report_columns`) of ``tuning`` on ``n_seeds`` report seeds (default
    4 × the tuning's), numbered from the one after the tuning's last: disjoint from them (module docstring).

    Parameters
    ----------
    tuning : Tuning
        The tuning whose minimax knobs are run.
    n_seeds : int, optional
        How many report seeds (default :data:`REPORT_FACTOR` × the tuning's).
    execution : Execution, optional
        As in :func:`isl_core.tune`: local threads, progress, cache.
    beyond : mapping
        More presets the table's filters run through (not tuned over; default :data:`BEYOND`).
    compute : bool, default True
        Compute what is not cached; False: return None instead (a page that must not wait).

    Returns
    -------
    HeldOut or None
        The seeds' contributions per coordinate of every reported filter and cell; None when not cached and
        ``compute`` is False.

    Examples
    --------
    >>> from isl_core import Execution, Sampling, TuningGrids, tune
    >>> from isl_core.scenario import PRESETS
    >>> from isl_core.scenario.heldout import held_out
    >>> grids = TuningGrids(isl_ell=(-2.0, 0.0), memory=(100.0,), robust_c=(2.0,), imm_switch=(1e-3,), imm_modes=(6,))
    >>> one_thread = Execution(workers=1, cache=False)
    >>> tuning = tune(1.0, presets={"constant": PRESETS["constant"]}, sampling=Sampling.first(2, horizon=5.0, burn=2.0),
    ...               grids=grids, execution=one_thread)
    >>> report = held_out(tuning, execution=one_thread, beyond={})
    >>> report.seeds, report.y.shape  # seeds × cells × filters × coordinates
    ((2, 3, 4, 5, 6, 7, 8, 9), (8, 1, 9, 3))
    """
    execution = local_threads(execution)
    if n_seeds is None:
        count = REPORT_FACTOR * len(tuning.seeds)
    else:
        count = check_int("n_seeds (report seeds)", n_seeds, lo=2, hi=100_000)
    first = max(tuning.seeds) + 1
    seed_ids = tuple(range(first, first + count))
    columns = report_columns(tuning)
    presets = tuning.preset_map()
    beyond = at_rate(beyond, tuning.rate)  # read at the tuning's rate, as its presets were
    key = {
        **cache_key(
            tuning.alpha,
            tuning.m,
            tuning.w,
            tuning.seeds,
            tuning.horizon,
            tuning.burn,
            presets,
            tuning.grids,
            tuning.refine,
        ),
        "report_seeds": list(seed_ids),
        "columns": [tuning.names[j] for j in columns],
        "beyond": {k: [s0, repr(sc)] for k, (_, s0, sc) in beyond.items()},
    }
    digest = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:20]
    path = cache_dir() / f"heldout-{digest}.npz"
    span = f"report seeds {seed_ids[0]}–{seed_ids[-1]} (the tuning's: {tuning.seeds[0]}–{tuning.seeds[-1]})"
    extra_cells = tuple(
        (b, per)
        for b, (_, _, sc) in enumerate(beyond.values())
        for per in scenario_periods(sc, tuning.horizon, burn=tuning.burn)
    )
    labels = {k: lab for k, (lab, _, _) in beyond.items()}
    found = load(path, key) if execution.cache else None
    if found is not None:
        y, seconds, origin = found[0], found[1], f"{span}; read from the cache {path}"
    elif not compute:
        return None
    else:
        only = [(tuning.family[j], tuning.knobs[j]) for j in columns[3:]]
        plans = [
            plan_preset(
                tuning.alpha, tuning.m, tuning.w, s0, sc, tuning.horizon, tuning.burn, tuning.grids, only, tuning.refine
            )
            for s0, sc in (*tuning.scenarios, *((s0, sc) for _, s0, sc in beyond.values()))
        ]
        start = time.perf_counter()
        y = np.concatenate(run_cells(plans, seed_ids, execution), axis=1)
        seconds = time.perf_counter() - start
        saved = execution.cache and save(path, y, seconds, key)
        origin = f"{span}; computed now in {seconds:.0f} s, {'cached in ' + str(path) if saved else 'not cached'}"
    ncell = len(tuning.cells)
    return HeldOut(seed_ids, columns, y[:, :ncell], seconds, origin, labels, extra_cells, y[:, ncell:])
