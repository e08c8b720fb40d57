"""Recorded series: readings of a signal at times of their own, every filter over them, the model fitted to them and
the filters judged without a truth (:ref:`data`).

* :mod:`~isl_core.series.record` — :class:`Series` and its validation (the reading model);
* :mod:`~isl_core.series.discretize` — the model between two readings, exactly (Van Loan);
* :mod:`~isl_core.series.likelihood` — the Kalman filter at given parameters and the log-likelihood;
* :mod:`~isl_core.series.run` — every filter over a series;
* :mod:`~isl_core.series.fit` — maximum likelihood, standard errors, AIC/BIC over m;
* :mod:`~isl_core.series.judge` — one-step prediction diagnostics on a held-out tail;
* :mod:`~isl_core.series.sources` — the shipped data sets and CSV files.

pandas and statsmodels (the ``data`` extra) are imported only by what needs them.
"""

from .discretize import van_loan
from .fit import Fit, OrderChoice, fit, select_order
from .likelihood import ReadingModel, loglik
from .record import MAX_READINGS, MIN_READINGS, Series, series, sigma_of_reading
from .run import SERIES_FILTERS, SeriesRun, SeriesTrack, run_filters

__all__ = [
    "MAX_READINGS",
    "MIN_READINGS",
    "SERIES_FILTERS",
    "Fit",
    "OrderChoice",
    "ReadingModel",
    "Series",
    "SeriesRun",
    "SeriesTrack",
    "fit",
    "loglik",
    "run_filters",
    "select_order",
    "series",
    "sigma_of_reading",
    "van_loan",
]
