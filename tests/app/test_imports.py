"""What a process pays to import the dashboard: every server process, its fork server and each long job's process
import the page, so the libraries only a computation needs (a fit, a confidence interval, a recorded series) are
imported where that computation runs, not at the top of a module the page imports."""

from __future__ import annotations

from _imports import loaded_by

#: imported by a fit (scipy.optimize), an interval (scipy.stats), a recorded series (statsmodels, pandas), a figure
ONLY_FOR_A_COMPUTATION = ("scipy.stats", "scipy.optimize", "statsmodels", "pandas", "matplotlib")


def test_importing_the_page_and_the_server_loads_no_library_only_a_computation_needs():
    assert loaded_by("import isl_core, app.app, app.page, app.serving.serve", ONLY_FOR_A_COMPUTATION) == []
