"""Compile every numba kernel of the core into its on-disk cache, once, before the test workers start.

``./scripts/test`` runs this first: a kernel the tests call but nobody compiled beforehand is otherwise compiled by
every pytest-xdist worker that meets it, at the same time, on the machine's two cores (the series filters, the
clairvoyant recursion, the IMM and variational steps, the Euler kernel of ``simulate_rmse``). Each call below is a
tiny run whose only purpose is that compilation; from the cache a later process loads the kernels in about a second.

The kernels come in two groups of similar compile time (:data:`GROUPS`), which ``./scripts/test`` compiles in two
processes side by side: ``python tests/_warm.py scenario`` and ``python tests/_warm.py others``; without an argument,
both in turn.
"""

from __future__ import annotations

import sys

import numpy as np


def warm_scenario() -> None:
    """The scenario loop, the largest kernel (half of a server's warm-up: :func:`app.serving.warmup.warm_core`), with
    every learner and noise."""
    from app.serving.warmup import warm_model, warm_scenario_loop
    from isl_core import Scenario, adaptive_kbf, variational_kbf
    from isl_core.filters import imm_kbf, robust_kbf
    from isl_core.scenario.run import simulate_scenario

    warm_scenario_loop()
    model = warm_model()
    learners = [adaptive_kbf(model), robust_kbf(model), variational_kbf(model), imm_kbf(model)]
    for scenario in (Scenario(noise="student", dof=4.0), Scenario(noise="outliers", sensor_interval=0.05)):
        simulate_scenario(model, 3.0, scenario, horizon=1.0, windows=2, extra=learners)


def warm_others() -> None:
    """The other half of a server's warm-up (the display run's kernels), the clairvoyant recursion, the Euler kernel of
    ``simulate_rmse`` and the series filters."""
    from app.serving.warmup import warm_model, warm_view
    from isl_core import Scenario, adaptive_kbf, isl_filter, simulate_rmse
    from isl_core.scenario import clairvoyant
    from isl_core.series import run_filters, series
    from isl_core.series.likelihood import ReadingModel

    warm_view()
    model = warm_model()
    clairvoyant(model, Scenario(sigma_knots=((0.5, 2.0),)), 0.01, 20)
    simulate_rmse(model, [isl_filter(model, 3.0), adaptive_kbf(model)], T=0.1, batches=2)
    rng = np.random.default_rng(0)
    readings = series(np.arange(60.0), np.cumsum(rng.standard_normal(60)) + rng.standard_normal(60))
    run_filters(readings, ReadingModel(2, 0.3, 0.4, 1.5))


GROUPS = {"scenario": warm_scenario, "others": warm_others}  #: the two groups, by the name the command line takes


def warm_kernels() -> None:
    """Every group in turn (module docstring)."""
    for warm in GROUPS.values():
        warm()


if __name__ == "__main__":
    if len(sys.argv) > 2 or (len(sys.argv) == 2 and sys.argv[1] not in GROUPS):
        sys.exit(f"usage: python tests/_warm.py [{' | '.join(GROUPS)}]")
    GROUPS[sys.argv[1]]() if len(sys.argv) == 2 else warm_kernels()
