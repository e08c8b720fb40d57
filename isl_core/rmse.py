"""Long runs that keep only squared errors (for sweeps and worst cases): :func:`simulate_rmse` (A.30,
:ref:`empirical-rmse`).

The same kernel, grid and start as :func:`isl_core.simulate`, without stored trajectories: per-batch sums of the
squared errors after a burn-in, for batch-means confidence intervals.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ._engine import check_progress, check_start, run_chunks
from .bounds import BOUNDS
from .filters.base import KIND_ADAPTIVE, FilterSpec
from .grid import MAX_STEPS, check_specs, grid
from .kernels.bundles import Trajectory
from .model import Model
from .riccati import kalman_bucy
from .validate import check_int, check_real

__all__ = ["RmseResult", "simulate_rmse"]


@dataclass(frozen=True)
class RmseResult:
    """Squared-error sums of a long run without stored trajectories.

    ``sq`` (batches, nf, m) holds per-batch sums of ``(Z_f,i − X_i)²`` over ``batch_len`` steps each
    (the last batch takes the remainder: ``counts``); ``s`` is the optimal RMSE √diag Δ (theory).
    ``burn`` (time) was left out before the first batch. ``sigma_hat`` (batches, nf): per-batch mean of an
    adaptive filter's σ̂, ``sigma_hat_final`` (nf,) its value at the end; nan for the other filters.
    """

    names: tuple[str, ...]
    sq: np.ndarray
    counts: np.ndarray
    s: np.ndarray
    r_min: float
    h: float
    T: float
    sigma_hat: np.ndarray | None = None
    sigma_hat_final: np.ndarray | None = None
    burn: float = 0.0

    def ratios(self) -> np.ndarray:
        """Whole-run ratios ``š_i/s_i`` (nf, m), (A.30)."""
        ratios: np.ndarray = np.sqrt(self.sq.sum(axis=0) / self.counts.sum()) / self.s
        return ratios

    def batch_ratios(self) -> np.ndarray:
        """Per-batch ratios (batches, nf, m), for batch-means confidence intervals."""
        ratios: np.ndarray = np.sqrt(self.sq / self.counts[:, None, None]) / self.s
        return ratios


def simulate_rmse(
    model: Model,
    filters: Sequence[FilterSpec],
    *,
    T: float,
    h: float | None = None,
    seed: int = 0,
    burn: float = 0.0,
    batches: int = 1,
    start: str = "stationary",
    step_filters: Sequence[FilterSpec] = (),
    progress: Callable[[float], None] | None = None,
) -> RmseResult:
    """Long run of ``filters`` on one truth (common random numbers), accumulating squared errors only.

    The first ``burn`` time units are left out of the averages; the rest is cut into ``batches``.
    ``step_filters``: more filters that count for the step size only (as in :func:`simulate`).
    ``progress(fraction)`` is called between kernel chunks; raising from it cancels the run.

    Parameters
    ----------
    model : Model
        The model.
    filters : sequence of FilterSpec
        The filters, on one truth and one noise.
    T : float
        Length of the run (time units).
    h : float, optional
        Step (default: :func:`isl_core.step_size` over the filters).
    seed : int, default 0
        The noise.
    burn : float, default 0.0
        Time left out at the start.
    batches : int, default 1
        Batches of the averages (for intervals).
    start, step_filters, progress : str, sequence of FilterSpec, callable
        As in :func:`isl_core.simulate`.

    Returns
    -------
    RmseResult
        The squared-error sums per batch; :meth:`RmseResult.ratios` the RMSE ratios ŝ/s.

    Examples
    --------
    >>> from isl_core import Model, isl_filter, kalman_bucy, optimal_kbf, simulate_rmse
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> kb = kalman_bucy(model)
    >>> res = simulate_rmse(model, [optimal_kbf(model, kb), isl_filter(model, model.beta)], T=5.0 / kb.r_min,
    ...                     batches=2)
    >>> res.names, res.sq.shape
    (('kbf', 'isl'), (2, 2, 3))
    """
    if not isinstance(model, Model):
        raise ValueError(f"model must be an isl_core.Model, got {type(model).__name__}")
    filters = check_specs("filters", model, filters, allow_empty=False)
    grid_only = check_specs("step_filters", model, step_filters, allow_empty=True)
    check_progress(progress)
    seed = BOUNDS.seed.whole(seed)
    batches = check_int("batches", batches, lo=1, hi=10_000)
    start = check_start(start)
    kb = kalman_bucy(model)
    T, h, n = grid(model, kb, [*filters, *grid_only], check_real("T", T, lo=0.0, lo_open=True), h, MAX_STEPS)
    burn_steps = min(int(check_real("burn", burn, lo=0.0, hi=T) / h), n - batches)
    if burn_steps < 0:
        raise ValueError(f"batches must be <= the number of steps {n}, got {batches}")
    adaptive = np.array([f.kind == KIND_ADAPTIVE for f in filters])
    sq, sig_sum, sig_final = run_chunks(
        model,
        kb,
        filters,
        h,
        n,
        seed,
        start=start,
        burn=burn_steps,
        batches=batches,
        out=Trajectory.none(len(filters), int(adaptive.sum()), model.m),
        progress=progress,
    )
    counts = np.full(batches, float((n - burn_steps) // batches))
    counts[-1] = (n - burn_steps) - counts[0] * (batches - 1)
    sigma_hat = np.full((batches, len(filters)), np.nan)
    sigma_hat[:, adaptive] = sig_sum / counts[:, None]
    final = np.full(len(filters), np.nan)
    final[adaptive] = sig_final
    return RmseResult(
        tuple(f.name for f in filters), sq, counts, kb.s.copy(), kb.r_min, h, T, sigma_hat, final, burn_steps * h
    )
