"""Where series come from: the shipped data sets, CSV files, and hostile bytes — each gets a series or a
ValueError that says why, never another exception."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("pandas", reason="the data extra: pip install 'isl[data]'")
pytest.importorskip("statsmodels", reason="the data extra: pip install 'isl[data]'")

from isl_core.series import Series
from isl_core.series.sources import DATASETS, LONG_MODEL, MAX_BYTES, csv_columns, dataset, read_csv


@pytest.mark.parametrize("name", list(DATASETS))
def test_shipped_data_sets(name):
    s = dataset(name)
    assert isinstance(s, Series) and np.all(np.diff(s.t) > 0)
    if name == "nile":
        assert s.n == 100 and s.regular
    if name == "co2":
        assert s.n > 2000 and 0 < (~s.present).sum() < 100
    if name == "long":
        assert s.n == LONG_MODEL[-1] >= 100_000 and "synthetic" in s.name


def test_csv_columns_dates_gaps_and_bom():
    data = "\ufeff# a comment\ndate,flow,other\n2020-01-01,1.5,x\n2020-01-03,,y\n" + "".join(
        f"2020-02-{d:02d},{d},z\n" for d in range(1, 12)
    )
    s = read_csv(data.encode(), value="flow")
    assert s.n == 13 and s.t[1] == 2.0 and np.isnan(s.z[1]) and s.z[-1] == 11.0
    one = read_csv(("v\n" + "\n".join(str(i * 0.5) for i in range(12))).encode())
    assert one.t[-1] == 11.0 and one.z[-1] == 5.5


def test_names_on_the_last_comment_line_as_numpy_writes_them():
    import io

    out = io.StringIO()
    t = np.arange(12.0)
    np.savetxt(out, np.column_stack([t, t**2]), delimiter=",", header="written by numpy\nt,square", fmt="%.9g")
    data = out.getvalue().encode()
    assert out.getvalue().splitlines()[1] == "# t,square" and csv_columns(data) == ["t", "square"]
    s = read_csv(data, time="t", value="square")
    assert np.array_equal(s.z, t**2)
    # a comment that names fewer columns than the rows hold is a comment, not the header
    data = b"# one,two,three\n" + b"".join(b"%d,%d\n" % (k, k) for k in range(12))
    assert csv_columns(data) == ["0", "0.1"]
    with pytest.raises(ValueError, match="the file is binary"):
        csv_columns(b"\x00\x01")


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (b"", "the file is empty"),
        (b"\x00\x01\x02abc", "binary"),
        (b"\xff\xfe\xfa,1\n", "not UTF-8"),
        (b"t,v\n" + b"".join(b"%d,%d\n" % (i, i) for i in range(12)) + b"12,abc\n", "row 13 has 'abc'"),
        (b"t,v\n" + b"".join(b"%d,1\n" % (i % 11) for i in range(12)), "row 12 has t = 0 after t = 10"),
        (b"t,v\n1,2\n", "at least 10 readings"),
    ],
)
def test_csv_refusals(data, message):
    with pytest.raises(ValueError) as err:
        read_csv(data)
    assert message in str(err.value)


def test_csv_column_not_found_and_size_limit():
    with pytest.raises(ValueError, match="column 'nope' is not in the file"):
        read_csv(b"t,v\n" + b"1,2\n" * 12, value="nope")
    with pytest.raises(ValueError, match="over 20 MB"):
        read_csv(b"1,2\n" * (MAX_BYTES // 4 + 1))


_cell = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-(10**30), 10**30).map(str),
    st.sampled_from(["", "nan", "NaN", "1e999", "-", "\ufeff1", "2020-01-01", "x", '"1,5"', " 3 "]),
)
_row = st.lists(_cell, min_size=1, max_size=3).map(",".join)
_text = st.lists(_row, min_size=0, max_size=40).map("\n".join).map(str.encode)
_hostile = st.one_of(_text, st.binary(max_size=200), _text.map(lambda b: b"\xef\xbb\xbf" + b))


@settings(max_examples=150, suppress_health_check=[HealthCheck.too_slow])
@given(_hostile)
def test_hostile_bytes_give_a_series_or_a_reason(data):
    try:
        s = read_csv(data)
    except ValueError as exc:
        assert str(exc)  # a reason, never an empty message
        return
    assert np.all(np.isfinite(s.t)) and np.all(np.diff(s.t) > 0) and not np.isinf(s.z).any()


def test_many_rows_are_refused_by_count():
    from isl_core.series import sources

    old = sources.MAX_ROWS
    sources.MAX_ROWS = 50  # the limit's check, without writing a million rows
    try:
        with pytest.raises(ValueError, match="more than 50 rows"):
            read_csv(b"t,v\n" + b"".join(b"%d,1\n" % i for i in range(60)))
    finally:
        sources.MAX_ROWS = old
