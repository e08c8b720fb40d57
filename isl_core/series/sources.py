"""Where a series comes from: the data sets that ship with the packages, and CSV files (:ref:`data-sources`).

Nothing is downloaded: ``nile`` and ``co2`` are statsmodels' own copies (``statsmodels.datasets``), ``long`` is
generated here from the model with a fixed seed (labelled synthetic). A CSV file is read by pandas, within
:data:`MAX_BYTES` and :data:`MAX_ROWS`, its time and value columns chosen by name (default: the first two; one
column alone is read as values at times 0, 1, 2, …); the names may stand on the last ``#`` line before the rows, as
numpy's ``savetxt`` writes them (the dashboard's downloads). A time column of dates is read as days since its first
date. Every refusal is a ``ValueError`` that names the column, the row and the fix.
"""

from __future__ import annotations

import io
import os
from pathlib import Path
from types import ModuleType
from typing import Any, cast

import numpy as np

from .discretize import van_loan
from .record import Series, series

__all__ = ["DATASETS", "LONG_MODEL", "MAX_BYTES", "MAX_ROWS", "csv_columns", "dataset", "read_csv"]

MAX_BYTES = 20_000_000  #: the largest CSV file read (20 MB)
MAX_ROWS = 1_000_000  #: the most rows of a CSV file read
#: the shipped data sets: name → what it is
DATASETS = {
    "nile": "the Nile's annual flow at Aswan, 1871–1970 (10⁸ m³; statsmodels.datasets.nile): 100 readings, yearly",
    "co2": "CO₂ at Mauna Loa, weekly 1958–2001 (ppm; statsmodels.datasets.co2): 2284 weeks, 59 of them missing",
    "long": "synthetic: 200 000 readings of the model m = 2, α = 0.05, β = 0.02, σ_r = 1, Δ = 1 (seed 0)",
}
LONG_MODEL = (2, 0.05, 0.02, 1.0, 200_000)  #: m, α, β, σ_r and N of the ``long`` data set


def _statsmodels_datasets() -> Any:  # statsmodels is untyped
    try:
        from statsmodels import datasets
    except ImportError as exc:
        raise ImportError("the shipped data sets need statsmodels: pip install 'isl[data]'") from exc
    return datasets


def _long() -> Series:
    m, alpha, beta, sigma_r, n = LONG_MODEL
    F, Q = van_loan(m, alpha, beta, np.array([1.0]))
    rng = np.random.default_rng(0)
    w = rng.standard_normal((n, m)) @ np.linalg.cholesky(Q[0]).T
    x = np.zeros((n, m))
    for k in range(1, n):  # X_k = F X_{k−1} + w_k: two coordinates, a few hundred ms
        x[k] = F[0] @ x[k - 1] + w[k]
    z = x[:, 0] + sigma_r * rng.standard_normal(n)
    return series(np.arange(float(n)), z, name="long (synthetic)", unit="step")


def dataset(name: str) -> Series:
    """The shipped data set ``name`` (one of :data:`!DATASETS`).

    Examples
    --------
    >>> from isl_core.series.sources import dataset
    >>> s = dataset("nile")
    >>> s.n, float(s.t[0]), float(s.z[0])
    (100, 1871.0, 1120.0)
    """
    if name == "nile":
        d = _statsmodels_datasets().nile.load_pandas().data
        return series(d["year"].to_numpy(float), d["volume"].to_numpy(float), name="nile", unit="year")
    if name == "co2":
        d = _statsmodels_datasets().co2.load_pandas().data
        year0 = d.index[0].year
        days = (d.index - d.index[0].replace(month=1, day=1)).days.to_numpy(float)
        return series(year0 + days / 365.25, d["co2"].to_numpy(float), name="co2", unit="year")
    if name == "long":
        return _long()
    raise ValueError(f"the data set must be one of {list(DATASETS)}, got {str(name)[:40]!r}")


def _pandas() -> Any:  # pandas is untyped
    try:
        import pandas as pd
    except ImportError as exc:
        raise ImportError("reading CSV files needs pandas: pip install 'isl[data]'") from exc
    return pd


def _text(data: bytes) -> str:
    if not data.strip():
        raise ValueError("the file is empty")
    if b"\x00" in data:
        raise ValueError("the file is binary, not CSV text (save it as CSV)")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValueError(f"the file is not UTF-8 text (byte {exc.start + 1}); save it as CSV in UTF-8") from None


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return not cell.strip()
    return True


def _names_from_comment(text: str) -> str:
    """``text`` with the column names numpy's ``savetxt`` writes as the last ``#`` line before the rows (its header
    convention, which ``numpy.genfromtxt(names=True)`` reads) made the header, when the first row holds numbers only
    and that line names as many columns; else ``text`` as it is."""
    pos, last = 0, None
    while pos < len(text):
        end = text.find("\n", pos)
        end = len(text) if end < 0 else end
        line = text[pos:end].strip()
        if line.startswith("#"):
            last = line
        elif line:
            cells = line.split(",")
            if last is not None and all(_is_number(c) for c in cells):
                names = [c.strip() for c in last.lstrip("#").split(",")]
                if len(names) == len(cells) and all(n and not _is_number(n) for n in names):
                    return text[:pos] + ",".join(names) + "\n" + text[pos:]
            return text
        pos = end + 1
    return text


def _column(frame: Any, name: str | None, default: int, what: str) -> Any:  # pandas is untyped
    if name is None:
        return frame.columns[default]
    if name not in frame.columns:
        cols = ", ".join(repr(str(c)) for c in frame.columns[:10])
        raise ValueError(f"{what} column {str(name)[:40]!r} is not in the file (its columns: {cols})")
    return name


def _numbers(pd: ModuleType, col: Any, what: str, dates: bool) -> np.ndarray:
    raw = col.astype(str).str.strip()
    values = pd.to_numeric(raw.where(raw != "", None), errors="coerce")
    bad = values.isna() & (raw != "") & (raw.str.lower() != "nan")
    if dates and bad.all():
        stamps = pd.to_datetime(raw, errors="coerce", format="mixed")
        if not stamps.isna().any():
            return cast("np.ndarray", ((stamps - stamps.iloc[0]).dt.total_seconds() / 86400.0).to_numpy(float))
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        raise ValueError(
            f"{what} column {str(col.name)[:40]!r} must hold numbers: row {row + 1} has {raw.iloc[row][:40]!r}"
            " (fix the cell, or leave a reading empty where it is missing)"
        )
    return cast("np.ndarray", values.to_numpy(float))


def csv_columns(data: bytes) -> list[str]:
    """The column names of a CSV file's header, from its bytes (what :func:`read_csv` would choose among). A file it
    cannot read — empty, binary, not UTF-8, over :data:`MAX_BYTES`, no header — is refused as :func:`read_csv`
    refuses it (``ValueError``)."""
    if len(data) > MAX_BYTES:
        raise ValueError(f"the file is over {MAX_BYTES // 1_000_000} MB: keep a part of it")
    pd, text = _pandas(), _text(bytes(data))
    try:
        frame = pd.read_csv(
            io.StringIO(_names_from_comment(text)), comment="#", dtype=str, nrows=0, skipinitialspace=True
        )
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as exc:
        raise ValueError(f"the file is not a readable CSV table: {str(exc).splitlines()[0][:120]}") from None
    return [str(c) for c in frame.columns]


def read_csv(
    source: str | os.PathLike[str] | bytes,
    *,
    time: str | None = None,
    value: str | None = None,
    name: str | None = None,
) -> Series:
    """A :class:`Series` from a CSV file (module docstring): ``source`` a path or the file's bytes; ``time`` and
    ``value`` the columns' names (default the first two). Lines starting with ``#`` are comments."""
    if isinstance(source, bytes | bytearray):
        data, label = bytes(source), name or "upload"
    else:
        path = Path(source)
        if not path.is_file():
            raise ValueError(
                f"SOURCE {str(source)[:80]!r} is neither a shipped data set ({', '.join(DATASETS)}) nor a file"
            )
        if path.stat().st_size > MAX_BYTES:
            raise ValueError(f"the file is over {MAX_BYTES // 1_000_000} MB: keep a part of it")
        data, label = path.read_bytes(), name or path.name
    if len(data) > MAX_BYTES:
        raise ValueError(f"the file is over {MAX_BYTES // 1_000_000} MB: keep a part of it")
    pd = _pandas()
    try:
        frame = pd.read_csv(
            io.StringIO(_names_from_comment(_text(data))),
            comment="#",
            dtype=str,
            keep_default_na=False,
            nrows=MAX_ROWS + 1,
            skipinitialspace=True,
        )
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as exc:
        raise ValueError(f"the file is not a readable CSV table: {str(exc).splitlines()[0][:120]}") from None
    if len(frame) > MAX_ROWS:
        raise ValueError(f"the file has more than {MAX_ROWS} rows: keep a part of it")
    if len(frame.columns) == 0 or len(frame) == 0:
        raise ValueError("the file has no rows of data")
    if len(frame.columns) == 1 and time is None:
        vcol = _column(frame, value, 0, "the value")
        z = _numbers(pd, frame[vcol], "the value", False)
        return series(np.arange(float(len(z))), z, name=label)
    tcol, vcol = _column(frame, time, 0, "the time"), _column(frame, value, 1, "the value")
    if tcol == vcol:
        raise ValueError(f"the time and value columns must differ, got {str(tcol)[:40]!r} for both")
    t = _numbers(pd, frame[tcol], "the time", True)
    z = _numbers(pd, frame[vcol], "the value", False)
    if np.isnan(t).any():
        row = int(np.flatnonzero(np.isnan(t))[0])
        raise ValueError(
            f"the time column {str(tcol)[:40]!r} has no time in row {row + 1} (fill it in or drop the row)"
        )
    return series(t, z, name=label)
