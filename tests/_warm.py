"""Compile every numba kernel of the core into its on-disk cache, once, before the test workers start.

``./scripts/test`` runs this first: a kernel the tests call but nobody compiled beforehand is otherwise compiled by
every pytest-xdist worker that meets it, at the same time, on the machine's two cores (the series filters, the
clairvoyant recursion, the IMM and variational steps, the Euler kernel of ``simulate_rmse``). Each call below is a
tiny run whose only purpose is that compilation; from the cache a later process loads the kernels in about a second.
"""

from __future__ import annotations

import numpy as np


def warm_kernels() -> None:
    """One tiny run through each family of kernels (module docstring)."""
    from app.serving.serve import warm_core
    from isl_core import Model, Scenario, adaptive_kbf, isl_filter, simulate_rmse, variational_kbf
    from isl_core.filters import imm_kbf, robust_kbf
    from isl_core.scenario import clairvoyant
    from isl_core.scenario.run import simulate_scenario
    from isl_core.series import run_filters, series
    from isl_core.series.likelihood import ReadingModel

    warm_core()  # what a server compiles: the display run and its min/max fold, the plain scenario loop
    model = Model.from_w(alpha=0.5, w=3.0, sigma=20.0, m=3)
    learners = [adaptive_kbf(model), robust_kbf(model), variational_kbf(model), imm_kbf(model)]
    for scenario in (Scenario(noise="student", dof=4.0), Scenario(noise="outliers", sensor_interval=0.05)):
        simulate_scenario(model, 3.0, scenario, horizon=1.0, windows=2, extra=learners)
    clairvoyant(model, Scenario(sigma_knots=((0.5, 2.0),)), 0.01, 20)
    simulate_rmse(model, [isl_filter(model, 3.0), adaptive_kbf(model)], T=0.1, batches=2)
    rng = np.random.default_rng(0)
    readings = series(np.arange(60.0), np.cumsum(rng.standard_normal(60)) + rng.standard_normal(60))
    run_filters(readings, ReadingModel(2, 0.3, 0.4, 1.5))


if __name__ == "__main__":
    warm_kernels()
