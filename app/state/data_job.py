"""The "Your data" tab's computations, off the event loop: reading a shipped set or an uploaded CSV file, and the fit
of the model with every filter judged on the held-out tail (:ref:`data`), as plain values a child process can send
back.

:func:`fit_series` is the tab's long job: :func:`isl_core.series.judge` (m chosen by BIC over 1 … 6, every filter run
with the fitted parameters, the diagnostics on the held-out tail) reduced to what the page shows — the fit, the
orders' AIC and BIC, the diagnostics, and the readings with every filter's estimate of X₁ and its ±3 band, at most
:data:`isl_core.decimate.DISPLAY_POINTS` samples per trace (min/max decimation: every drawn point is a real one; a
series that short is drawn whole). The downloads (:func:`estimates_csv`, :func:`fit_json`) are computed from the
series and the fit again when asked for, like the trajectories' CSV.
"""

from __future__ import annotations

import io
import json
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from isl_core.cli.commands import nan_to_none
from isl_core.cli.data import summary
from isl_core.decimate import DISPLAY_POINTS, minmax_indices
from isl_core.series import Series, dataset, judge, read_csv, run_filters
from isl_core.series.run import sigma_range
from isl_core.series.sources import csv_columns

__all__ = ["MAX_UPLOAD", "DataResult", "Upload", "estimates_csv", "fit_json", "fit_series", "load", "read_upload"]

#: the largest file the page takes (10 MB): the browser sends it to the server in one message, which the connection
#: carries up to 20 MB — a file base64-encoded, 4/3 of its size
MAX_UPLOAD = 10_000_000
MAX_ROWS_CSV = 20_000  #: rows of the estimates' CSV at most (every k-th time beyond; the header says which)


@dataclass(frozen=True)
class Upload:
    """A CSV file read: its header's ``columns``, the columns chosen, and the validated ``series``."""

    columns: tuple[str, ...]
    time: str | None
    value: str | None
    series: Series


@dataclass(frozen=True)
class Line:
    """One filter's drawn estimate of X₁: times ``t``, ``y``, and its ±3 band ``low``/``high`` (None where the filter
    states no variance)."""

    name: str
    label: str
    t: np.ndarray
    y: np.ndarray
    low: np.ndarray | None
    high: np.ndarray | None


@dataclass(frozen=True)
class DataResult:
    """What the tab shows of a fit (module docstring): ``summary`` (the command line's JSON: fit, orders, ν,
    diagnostics), the readings ``t``, ``z`` as drawn, each filter's :class:`Line`, the first held-out time
    ``t_split``, and whether the traces were decimated (``points`` samples per trace at most)."""

    name: str
    n: int
    summary: dict
    t: np.ndarray
    z: np.ndarray
    lines: tuple[Line, ...]
    t_split: float
    decimated: bool
    points: int


def load(name: str) -> Series:
    """A shipped data set (:func:`isl_core.series.dataset`)."""
    return dataset(name)


def read_upload(data: bytes, time: str | None = None, value: str | None = None, name: str = "upload") -> Upload:
    """An uploaded file's bytes read as a series (:func:`isl_core.series.read_csv`) — refused (``ValueError``, in
    words) over :data:`MAX_UPLOAD` before anything is parsed; ``time``/``value`` the columns (default the first
    two, or one that is no longer in the file)."""
    if not isinstance(data, bytes | bytearray):
        raise ValueError("the file could not be read (send it again)")
    if len(data) > MAX_UPLOAD:
        raise ValueError(f"the file has {len(data):,} bytes, over the limit of {MAX_UPLOAD // 1_000_000} MB")
    columns = tuple(csv_columns(bytes(data)))
    if len(columns) < 2:  # one column: readings at times 0, 1, 2, …
        time = value = None
    else:
        time = time if time in columns else columns[0]
        value = value if value in columns and value != time else next(c for c in columns if c != time)
    return Upload(columns, time, value, read_csv(bytes(data), time=time, value=value, name=name))


def _shown(n: int, traces: list[np.ndarray], points: int) -> np.ndarray:
    """The samples drawn: all of them up to ``points``, else the union of each trace's min/max samples."""
    if n <= points:
        return np.arange(n)
    keep = [
        minmax_indices(np.where(np.isfinite(y), y, np.nanmean(y) if np.isfinite(y).any() else 0.0), points)
        for y in traces
    ]
    return np.unique(np.concatenate(keep))


def fit_series(
    series: Series,
    holdout: float,
    *,
    m: int | None = None,
    points: int = DISPLAY_POINTS,
    progress: Callable[[float], None] | None = None,
) -> DataResult:
    """Fit, run and judge ``series`` with ``holdout`` of its times held out, at order ``m`` (None: chosen by BIC)
    (module docstring)."""
    j = judge(series, m=m, holdout=holdout, progress=progress)
    tracks = j.run.tracks
    traces = [series.z, *(tr.estimate[:, 0] for tr in tracks)]
    idx = _shown(series.n, traces, points)
    t = series.t[idx]
    lines = []
    for tr in tracks:
        y = tr.estimate[idx, 0]
        low = high = None
        if tr.variance is not None:
            sd = np.sqrt(np.maximum(tr.variance[idx, 0], 0.0))
            low, high = y - 3.0 * sd, y + 3.0 * sd
        lines.append(Line(tr.name, tr.label, t, y, low, high))
    return DataResult(
        series.name,
        series.n,
        summary(series, j),
        t,
        series.z[idx],
        tuple(lines),
        float(series.t[j.split]),
        len(idx) < series.n,
        points,
    )


def fit_json(result: DataResult) -> str:
    """The fit of ``result`` as JSON: the command line's ``isl data --json`` (NaN as null)."""
    return json.dumps(nan_to_none(result.summary), indent=2, allow_nan=False) + "\n"


def estimates_csv(series: Series, result: DataResult) -> str:
    """Every filter's estimates over ``series`` at the fitted parameters of ``result`` (the run the page draws) as
    CSV: ``#`` lines saying what was fitted, then ``t, z`` and per filter its estimate of each coordinate and, where
    it states one, the standard deviation of X₁'s; every k-th time when the series has more than
    :data:`MAX_ROWS_CSV`."""
    from isl_core.series import ReadingModel

    f = result.summary["fit"]
    params = ReadingModel(f["m"], f["alpha"], f["beta"], f["sigma_r"])
    split = result.summary["split"]
    run = run_filters(series, params, nu=result.summary["nu"], sigma_range_=sigma_range(series.head(split)))
    every = max(1, math.ceil(series.n / MAX_ROWS_CSV))
    rows = np.arange(0, series.n, every)
    cols, data = ["t", "z"], [series.t[rows], series.z[rows]]
    for tr in run.tracks:
        for i in range(params.m):
            cols.append(f"{tr.name}_X{i + 1}")
            data.append(tr.estimate[rows, i])
        if tr.variance is not None:
            cols.append(f"{tr.name}_sd_X1")
            data.append(np.sqrt(np.maximum(tr.variance[rows, 0], 0.0)))
    head = [
        f"isl data: {series.name}; {series.n} times, {int(series.present.sum())} readings (z empty where missing)",
        f"fit on the times before t = {result.t_split:.17g}: m={params.m} alpha={params.alpha:.17g}"
        f" beta={params.beta:.17g} sigma_r={params.sigma_r:.17g}; ISL nu={result.summary['nu']:.17g}",
        f"rows: every {every} time(s) ({len(rows)} rows); each filter's estimate after the reading at t",
        ",".join(cols),
    ]
    body = io.StringIO()
    np.savetxt(body, np.column_stack(data), delimiter=",", fmt="%.9g")
    return "".join(f"# {line}\n" for line in head) + body.getvalue().replace("nan", "")  # a missing value: empty
