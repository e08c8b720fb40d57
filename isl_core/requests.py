"""Requests as values: what a simulated grid samples (:class:`Sampling`) and how it runs (:class:`Execution`).

:func:`isl_core.sweep`, :func:`isl_core.worst_case`, :func:`isl_core.recommend_nu`, :func:`isl_core.tune` and
:func:`isl_core.scenario_table` take one of each instead of eight loose keywords, so that a caller states a request
once and hands it on (the recommendation passes its sampling to the sweep that verifies it, the scenario table its
sampling to the tuning and its execution to the held-out runs). Both are frozen and checked at construction: a bad
field raises ``ValueError`` naming it and its range, before any work starts.

``seeds`` is always a sequence of seeds; a count of them is ``n_seeds`` (:meth:`Sampling.first` takes seeds
0 … ``n_seeds`` − 1).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .bounds import BOUNDS
from .validate import check_int, check_real, short

__all__ = ["SWEEP_BURN", "Execution", "Sampling"]

SWEEP_BURN = 10.0  #: the burn-in a sweep leaves out of every average, in units of the settling time 1/r_min


@dataclass(frozen=True)
class Sampling:
    """What a simulated grid samples: every point is run once per seed of ``seeds`` (independent noises), after a
    burn-in of ``burn`` and over ``horizon`` (both in units of the settling time 1/r_min, lengthened for a slow
    filter, :func:`!isl_core.sweep.group_length`), cut into ``batches`` batches per seed for the intervals at
    confidence ``level``.

    Examples
    --------
    >>> from isl_core import Sampling
    >>> Sampling.first(3, horizon=20.0).seeds
    (0, 1, 2)
    >>> Sampling(seeds=(5,), batches=1)
    Traceback (most recent call last):
    ...
    ValueError: batches must be an integer >= 2 and <= 1000, got 1
    """

    seeds: tuple[int, ...] = (0, 1)
    horizon: float = 1000.0
    burn: float = SWEEP_BURN
    batches: int = 10
    level: float = 0.95

    def __post_init__(self) -> None:
        object.__setattr__(self, "seeds", BOUNDS.seed.wholes(self.seeds, "seeds"))
        object.__setattr__(self, "horizon", BOUNDS.horizon.real(self.horizon))
        object.__setattr__(self, "burn", check_real("burn", self.burn, lo=0.0))
        # one seed: its interval needs at least two batches
        lo = 2 if len(self.seeds) == 1 else 1
        object.__setattr__(self, "batches", check_int("batches", self.batches, lo=lo, hi=1000))
        level = check_real("level", self.level, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
        object.__setattr__(self, "level", level)

    @classmethod
    def first(cls, n_seeds: int, **fields: Any) -> Sampling:
        """The sampling of seeds 0 … ``n_seeds`` − 1 (other ``fields`` as in the class)."""
        n = check_int("n_seeds", n_seeds, lo=1, hi=10_000)
        return cls(seeds=tuple(range(n)), **fields)

    @property
    def n_seeds(self) -> int:
        """How many seeds."""
        return len(self.seeds)


@dataclass(frozen=True)
class Execution:
    """How a simulated grid runs: on a local pool of ``workers`` threads (None: the CPU count) or on ``executor``
    (a ``concurrent.futures.Executor`` or a ``dask.distributed.Client``), in chunks of ``chunk`` tasks;
    ``progress(fraction)`` is told the fraction done (an exception raised from it cancels the job,
    :mod:`!isl_core.jobs`); ``cache``: a job that has an on-disk cache reads and fills it (the scenarios' tuning),
    one without ignores it. Results never depend on the execution.
    """

    workers: int | None = None
    executor: Any = None
    chunk: int = 1
    progress: Callable[[float], None] | None = None
    cache: bool = True

    def __post_init__(self) -> None:
        if self.workers is not None:
            object.__setattr__(self, "workers", check_int("workers", self.workers, lo=1, hi=256))
        object.__setattr__(self, "chunk", check_int("chunk", self.chunk, lo=1))
        if self.progress is not None and not callable(self.progress):
            raise ValueError(f"progress must be a callable or None, got {short(self.progress)}")
        if not isinstance(self.cache, bool):
            raise ValueError(f"cache must be True or False, got {short(self.cache)}")

    @property
    def n_workers(self) -> int:
        """The local pool's threads: ``workers``, or the CPU count."""
        return self.workers if self.workers is not None else (os.cpu_count() or 2)
