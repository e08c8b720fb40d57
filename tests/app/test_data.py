"""The "Your data" tab's room without a browser: hostile files through its upload handler (a series or a refusal in
words beside the input, never an exception in the log), the limit enforced before parsing, the fit's result and
downloads, and the data set in links."""

from __future__ import annotations

import base64
import json
import logging

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.state import AppState
from app.state import data as data_room
from app.state.data_job import MAX_UPLOAD
from app.urlsync import read_query
from app.views.data import DataView
from app.views.file_picker import FilePicker

pytest.importorskip("pandas", reason="the data extra: pip install 'isl[data]'")


@pytest.fixture
def fits(monkeypatch):
    """The room's fits, recorded instead of run (the hostile files' test checks the reading, fast)."""
    asked = []
    monkeypatch.setattr(data_room.DataRoom, "fit", lambda self: asked.append(self.series))
    return asked


_cell = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-(10**30), 10**30).map(str),
    st.sampled_from(["", "nan", "NaN", "1e999", "1e300", "-1e200", "\ufeff1", "2020-01-01", "x", '"1,5"', " 3 "]),
)
_row = st.lists(_cell, min_size=1, max_size=3).map(",".join)
_text = st.lists(_row, min_size=0, max_size=40).map("\n".join).map(str.encode)
_sorted = st.lists(st.floats(-1e6, 1e6), min_size=10, max_size=40).map(
    lambda v: ("t,v\n" + "".join(f"{k},{x!r}\n" for k, x in enumerate(v))).encode()
)
_hostile = st.one_of(
    _text,
    _sorted,
    st.binary(max_size=200),
    _text.map(lambda b: b"\xef\xbb\xbf" + b),  # a byte-order mark
    _sorted.map(lambda b: b.replace(b"\n3,", b"\n1,", 1)),  # a time that goes back
)


@settings(
    derandomize=True, max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(_hostile)
def test_hostile_files_give_a_series_or_a_refusal_beside_the_input(fits, caplog, data):
    state = AppState()
    room = state.data
    with caplog.at_level(logging.WARNING):
        room.upload(data, "hostile.csv")
    assert [r for r in caplog.records if r.levelno >= logging.WARNING] == []
    if room.upload_note:
        assert room.upload_note.startswith("Refused: ") and room.upload_note.endswith("Nothing was fitted.")
        assert room.series is None and fits == []
    else:
        assert room.series is not None and fits == [room.series] and room.source == "upload"
        assert room.series.n >= 10 and np.all(np.diff(room.series.t) > 0)
    fits.clear()


def test_a_file_over_the_limit_is_refused_before_it_is_parsed(fits, monkeypatch):
    parsed = []
    monkeypatch.setattr(data_room, "read_upload", lambda *a: parsed.append(a))
    state = AppState()
    state.data.upload(b"t,v\n" + b"1,2\n" * (MAX_UPLOAD // 4), "big.csv")
    assert parsed == [] and fits == [] and state.data.series is None
    assert state.data.upload_note == (
        f"Refused: big.csv has {MAX_UPLOAD + 4:,} bytes, over the limit of {MAX_UPLOAD // 1_000_000} MB. "
        "Nothing was fitted."
    )


def test_a_file_the_browser_did_not_send_is_refused_in_words():
    state = AppState()
    state.data.too_large("huge.csv", "16000000")  # what the page's file picker reports instead of the file
    assert (
        state.data.upload_note == "Refused: huge.csv has 16,000,000 bytes, over the limit of 10 MB. Nothing was fitted."
    )
    state.data.too_large(None, "9" * 40)  # whatever a hostile page reports
    assert state.data.upload_note.startswith("Refused: the file has more, over the limit of 10 MB.")


def test_the_file_pickers_messages_reach_the_room_a_file_or_only_its_size(fits):
    """What the page's file picker sends (app.views.file_picker): a file within the limit, base64, read as the upload;
    over the limit, its name and size only, refused in words; a message that cannot be decoded refused in words."""
    state = AppState()
    picker = DataView(state=state)._file_input()[0]
    assert isinstance(picker, FilePicker) and picker.max_size == MAX_UPLOAD
    fits.clear()  # (the view asked for the default data set's)
    picker._handle_msg({"name": "mine.csv", "data": base64.b64encode(_small()).decode()})
    assert state.data.upload_note == "" and len(fits) == 1 and fits[0] is state.data.series and fits[0].n == 50
    picker._handle_msg({"name": "huge.csv", "size": 16_000_000})
    assert state.data.upload_note == (
        "Refused: huge.csv has 16,000,000 bytes, over the limit of 10 MB. Nothing was fitted."
    )
    for hostile in ({"name": "bad.csv", "data": "not base64!"}, {"name": "bad.csv", "data": 7}):
        state.data.upload_note = ""
        picker._handle_msg(hostile)
        assert state.data.upload_note.startswith("Refused: the file could not be read"), hostile
    picker._handle_msg(["not", "a", "message"])  # ignored
    assert len(fits) == 1


def _small() -> bytes:
    rng = np.random.default_rng(11)
    z = np.cumsum(rng.standard_normal(50)) + rng.standard_normal(50)
    return ("day,level,note\n" + "".join(f"{k},{x:.6g},a\n" for k, x in enumerate(z))).encode()


def test_an_upload_is_fitted_judged_and_downloaded_and_the_other_column_refused(caplog):
    state = AppState(tab="data")
    room = state.data
    with caplog.at_level(logging.WARNING):
        room.upload(_small(), "levels.csv")
        res = room.result
        assert room.columns == ["day", "level", "note"] and (room.time_column, room.value_column) == ("day", "level")
        assert res is not None and res.n == 50 and res.summary["split"] == 40 and res.t_split == 40.0
        assert [d["name"] for d in res.summary["diagnostics"]] == [line.name for line in res.lines]
        assert room.note.startswith("Fitted in ") and "m = " in room.note
        f = res.summary["fit"]  # the legend speaks the series' units, not the filters' inner ones
        assert res.lines[0].label == f"Kalman (σ_r = {f['sigma_r']:.4g} given)"
        assert res.lines[1].label == f"ISL (ν = {res.summary['nu']:.4g})"
        csv = room.estimates_file()
        head = [line for line in csv.splitlines() if line.startswith("#")]
        assert head[-1].startswith("# t,z,kalman_X1,") and len(csv.splitlines()) == len(head) + 50
        assert json.loads(room.fit_file())["fit"]["m"] == res.summary["fit"]["m"]
        room.choose_columns("day", "note")  # not numbers: refused beside the input, the fit kept
        assert room.upload_note.startswith("Refused: the value column 'note' must hold numbers: row 1 has 'a'")
        assert room.result is res
        room.holdout = 0.3  # refitted with the new share
        assert room.result.summary["split"] == 35
        room.order = 1  # m given: one fit, no table of orders
        assert room.result.summary["fit"]["m"] == 1 and room.result.summary["orders"] == []
        assert "m = 1 given" in room.note
    assert [r for r in caplog.records if r.levelno >= logging.WARNING] == []
    room.release()
    assert room.result is None and room.series is None and room._file is None  # nothing kept after the session


def test_the_data_set_is_in_links_and_a_bad_one_is_refused_in_words():
    values, problems = read_query("?tab=data&data_set=co2&data_holdout=0.3&data_m=2")
    assert values == {"tab": "data", "data_set": "co2", "data_holdout": 0.3, "data_m": 2} and problems == {}
    state = AppState()
    bad = state.set_inputs({"data_set": "rhine", "data_holdout": 2.0}, link=True)
    assert bad == [
        'data set (data_set=… in the link) must be one of nile, co2, long, upload; "rhine" is not one of them',
        "held-out share (data_holdout=… in the link) must be a number from 0.05 to 0.9; 2 is above that range",
    ]
    assert (state.data.source, state.data.holdout) == ("nile", 0.2)


@pytest.mark.parametrize(
    "values, times",
    [(np.full(50, 7.0), np.arange(50.0)), (1e140 * np.cos(np.arange(50.0)), 1e-20 * np.arange(50.0))],
    ids=["constant", "huge-and-dense"],
)
def test_extreme_files_are_fitted_or_refused_in_words(caplog, values, times):
    rows = "".join(f"{float(t)!r},{float(z)!r}\n" for t, z in zip(times, values, strict=True))
    state = AppState()
    with caplog.at_level(logging.WARNING):
        state.data.upload(("t,z\n" + rows).encode(), "extreme.csv")
    assert [r for r in caplog.records if r.levelno >= logging.WARNING] == []
    res = state.data.result
    if res is None:
        assert state.data.note == "Failed: the readings are all equal: there is no motion or noise to fit."
    else:
        assert np.all(np.isfinite(res.z)) and all(np.all(np.isfinite(line.y)) for line in res.lines)
