"""The worst-case room: each filter's largest RMSE ratio over the plausible σ range, per α, as a long job.

Its inputs are the table's rows (α values), the σ grid and the horizon; the σ range and σ̄ are the extra filters'
(:class:`app.state.BaselinesRoom`), m, w and the seed the model's. The table is :func:`app.extras.worst_case_table`.
"""

from __future__ import annotations

from functools import partial
from typing import ClassVar

import param

from isl_core import SWEEP_BURN, WORST_CASE_FILTERS, WorstCaseTable

from ..extras import ALPHA_BOUNDS, worst_case_table
from ..inputs import Real, Reals, Whole
from ..text import R_MIN, per_r_min
from .room import LongJobRoom

__all__ = ["WorstCaseRoom"]


class WorstCaseRoom(LongJobRoom):
    """Inputs, table and job of the worst case over σ (the module docstring); keys ``wc_…``."""

    KEYS: ClassVar[dict[str, str]] = {"wc_alphas": "alphas", "wc_n_sigma": "n_sigma", "wc_horizon": "horizon"}

    alphas = Reals(
        [0.04, 0.2, 1.0, 5.0, 25.0],
        item_bounds=ALPHA_BOUNDS,
        bounds=(1, 5),
        label="α values",
        doc=("Rows of the worst-case table: 1 to 5 values of α in [0.001, 100]; paper A, Fig. 2: 0.04 … 25."),
    )
    n_sigma = Whole(
        5,
        bounds=(2, 11),
        label="σ grid points",
        doc=("Log-spaced σ values (both ends included) over which each worst case is taken."),
    )
    horizon = Real(
        100.0,
        bounds=(20.0, 2000.0),
        label=f"worst-case horizon (× 1/{R_MIN})",
        doc=(f"Length of each simulated run of the worst-case table in units of 1/{R_MIN}; ±2 % needs about 1000."),
    )

    table = param.ClassSelector(class_=WorstCaseTable, default=None, allow_None=True, precedence=-1)

    def compute(self) -> None:
        """Simulate the worst-case table as the session's long job (progress in ``progress``; cancellable)."""
        if blocked := self.refused_among((*self.KEYS, "sigma_min", "sigma_max", "sigma_design")):
            self.note = blocked
            return
        host, extra = self._host, self._host.baselines
        fn = partial(
            worst_case_table,
            tuple(self.alphas),
            sigma_range=extra.sigma_range,
            n_sigma=self.n_sigma,
            m=host.m,
            w=host.w,
            sigma_design=extra.sigma_design,
            horizon=self.horizon,
            seed=host.seed,
        )
        self._task.start(
            fn,
            self._apply,
            (f"Simulating {len(self.alphas)} α × {self.n_sigma} σ, {len(WORST_CASE_FILTERS)} filters on each run …"),
        )

    def _apply(self, outcome) -> None:
        """Show a computed worst-case table and where its numbers come from."""
        t: WorstCaseTable = outcome.value
        lo, hi = t.sigma_range
        k_lo, k_hi = float(t.stretch.min()), float(t.stretch.max())
        longer = (
            ""
            if k_hi == 1.0
            else (
                f", both lengthened ×{k_lo:.3g}–×{k_hi:.3g} where a filter settles slower than the optimal one (B.46)"
            )
        )
        self.param.update(
            table=t,
            note=(
                f"Simulated in {outcome.seconds:.1f} s: σ ∈ [{lo:g}, {hi:g}] ({len(t.sigmas)} values), m = {t.m}, "
                f"w = {t.w:g}, seed {t.seeds[0]}. Each run averages over {per_r_min(t.horizon)} after a burn-in of "
                f"{per_r_min(SWEEP_BURN)}{longer}; 95 % batch-means intervals."
            ),
        )

    def release(self) -> None:
        """The session ends: drop the table without a redraw."""
        with param.parameterized.discard_events(self):
            self.table = None
