"""Running a grid of simulations: tasks, progress, cancellation, on local threads or any executor.

The sweep (:func:`isl_core.sweep`), the worst case (:func:`isl_core.worst_case`) and through them the recommendation
(:func:`isl_core.recommend_nu`) cut their work into :class:`Task` s — one long run of several filters on common
noise — and hand them to :func:`run`:

* where, the job's :class:`isl_core.Execution` says: ``executor=None``, a local pool of ``workers`` threads (the
  kernel releases the GIL); a ``concurrent.futures`` executor, or a ``dask.distributed.Client`` (optional extra
  ``isl[dask]``): tasks go out in chunks of ``chunk``.
  A task's result depends only on the task, never on the executor, the workers or the chunking.
* ``progress(fraction)``: the overall fraction done, weighted by each task's cost (steps × filters), called one
  call at a time from worker threads. An exception raised from it cancels: queued tasks are dropped and running
  ones stop at their next report (≤ one kernel chunk); the exception propagates.
* a task that fails cancels the others and its own error propagates (not the cancellations it caused).
"""

from __future__ import annotations

import concurrent.futures as cf
import functools
import threading
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .filters.base import FilterSpec
from .model import Model
from .requests import Execution
from .rmse import simulate_rmse
from .simulate import DivergenceError

__all__ = ["Cancelled", "Progress", "Task", "TaskResult", "run", "run_task"]


@dataclass(frozen=True)
class Task:
    """One run: ``model``, ``filters`` (the optimal one first), its grid (``T``, ``h``, ``steps``), burn-in, batches
    and seed; ``key`` names its place in the caller's grid. Picklable for process pools and Dask."""

    key: Hashable
    model: Model
    filters: tuple[FilterSpec, ...]
    T: float
    h: float
    burn: float
    batches: int
    seed: int
    steps: int

    @property
    def cost(self) -> float:
        """Relative cost: steps × (filters + the truth)."""
        return float(self.steps * (len(self.filters) + 1))


@dataclass(frozen=True)
class TaskResult:
    """Squared-error sums ``sq`` (batches, filters, m) and steps per batch ``counts`` of the task ``key``; a filter
    that diverged has nan sums."""

    key: Hashable
    sq: np.ndarray
    counts: np.ndarray


class Cancelled(RuntimeError):
    """Raised in the other tasks once one failed or the progress callback raised."""


def run_task(task: Task, progress: Callable[[float], None] | None = None) -> TaskResult:
    """Run ``task``; a diverged filter gets nan (the others are rerun one by one on the same noise)."""
    kw: dict[str, Any] = {"T": task.T, "h": task.h, "burn": task.burn, "batches": task.batches, "seed": task.seed}
    try:
        res = simulate_rmse(task.model, task.filters, progress=progress, **kw)
        return TaskResult(task.key, res.sq, res.counts)
    except DivergenceError:  # the noise stream does not depend on the filter set: rerun them one by one
        parts, counts = [], None
        for spec in task.filters:
            try:
                one = simulate_rmse(task.model, [spec], **kw)
                parts.append(one.sq[:, 0])
                counts = one.counts
            except DivergenceError:
                parts.append(np.full((task.batches, task.model.m), np.nan))
        if counts is None:  # every filter diverged: the batches are still the grid's
            counts = np.full(task.batches, np.nan)
        return TaskResult(task.key, np.stack(parts, axis=1), counts)


def _run_chunk(tasks: Sequence[Task]) -> list[TaskResult]:
    return [run_task(t) for t in tasks]


class Progress:
    """Thread-safe aggregation of per-task fractions into one overall fraction; also the cancel switch."""

    def __init__(self, weights: dict[Hashable, float], callback: Callable[[float], None] | None):
        self.weights, self.callback = weights, callback
        self.total = float(sum(weights.values()))
        self.done = dict.fromkeys(weights, 0.0)
        self.lock = threading.Lock()
        self.cancelled = threading.Event()

    def update(self, key: Hashable, fraction: float) -> None:
        with self.lock:
            if self.cancelled.is_set():
                raise Cancelled("cancelled")
            self.done[key] = fraction
            overall = sum(self.weights[k] * f for k, f in self.done.items()) / self.total
            if self.callback is not None:
                try:
                    self.callback(overall)
                except BaseException:
                    self.cancelled.set()  # no further report reaches the callback
                    raise

    def stop(self, futures: Sequence[cf.Future[Any]]) -> None:
        """Cancel queued tasks; running ones raise at their next progress report."""
        self.cancelled.set()
        for f in futures:
            f.cancel()


def _local(tasks: Sequence[Task], workers: int, prog: Progress) -> list[TaskResult]:
    def job(task: Task) -> TaskResult:
        return run_task(task, progress=functools.partial(prog.update, task.key))

    with cf.ThreadPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(job, t) for t in tasks]
        try:
            cf.wait(futures, return_when=cf.FIRST_EXCEPTION)
        except BaseException:  # e.g. KeyboardInterrupt while waiting
            prog.stop(futures)
            raise
        failed = [e for f in futures if f.done() and not f.cancelled() and (e := f.exception()) is not None]
        if failed:
            prog.stop(futures)  # report the cause, not the cancellations it triggered in other tasks
            raise next((e for e in failed if not isinstance(e, Cancelled)), failed[0])
        return [f.result() for f in futures]


def _remote(tasks: Sequence[Task], executor: Any, chunk: int, prog: Progress) -> list[TaskResult]:
    chunks = [tasks[i : i + chunk] for i in range(0, len(tasks), chunk)]
    if isinstance(executor, cf.Executor):
        futures = [executor.submit(_run_chunk, c) for c in chunks]
        completed = cf.as_completed(futures)
    else:  # a dask.distributed.Client
        from distributed import as_completed  # optional extra isl[dask]

        futures = [executor.submit(_run_chunk, c, pure=False) for c in chunks]
        completed = as_completed(futures)  # type: ignore[no-untyped-call]  # distributed is untyped
    out: list[TaskResult] = []
    try:
        for fut in completed:
            part = fut.result()
            out.extend(part)
            for result in part:
                prog.update(result.key, 1.0)
    except BaseException:
        for f in futures:
            f.cancel()
        raise
    return out


def run(tasks: Sequence[Task], execution: Execution) -> list[TaskResult]:
    """Every task's result (in no particular order), on local threads or ``execution.executor`` (module
    docstring)."""
    prog = Progress({t.key: t.cost for t in tasks}, execution.progress)
    if execution.executor is None:
        return _local(tasks, execution.n_workers, prog)
    return _remote(tasks, execution.executor, execution.chunk, prog)
