"""Recorded series: readings of a signal at times of their own, every filter over them, the model fitted to them and
the filters judged without a truth (:ref:`data`).

* :mod:`~isl_core.series.record` — :class:`Series` and its validation (the reading model);
* :mod:`~isl_core.series.discretize` — the model between two readings, exactly (Van Loan);
* :mod:`~isl_core.series.likelihood` — the Kalman filter at given parameters and the log-likelihood;
* :mod:`~isl_core.series.run` — every filter over a series;
* :mod:`~isl_core.series.mle` — maximum likelihood, standard errors, AIC/BIC over m;
* :mod:`~isl_core.series.diagnostics` — one-step prediction diagnostics on a held-out tail;
* :mod:`~isl_core.series.sources` — the shipped data sets and CSV files.

pandas and statsmodels (the ``data`` extra) are imported only by what needs them.
"""

from .diagnostics import Diagnostics, Judgement, judge
from .discretize import van_loan
from .likelihood import ReadingModel, loglik
from .mle import Fit, OrderChoice, fit, select_order
from .record import MAX_READINGS, MIN_READINGS, Series, series, sigma_of_reading
from .run import SERIES_FILTERS, SeriesRun, SeriesTrack, run_filters
from .sources import DATASETS, dataset, read_csv

__all__ = [
    "DATASETS",
    "MAX_READINGS",
    "MIN_READINGS",
    "SERIES_FILTERS",
    "Diagnostics",
    "Fit",
    "Judgement",
    "OrderChoice",
    "ReadingModel",
    "Series",
    "SeriesRun",
    "SeriesTrack",
    "dataset",
    "fit",
    "judge",
    "loglik",
    "read_csv",
    "run_filters",
    "select_order",
    "series",
    "sigma_of_reading",
    "van_loan",
]
