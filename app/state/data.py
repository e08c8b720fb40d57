"""The "Your data" tab's room: a recorded series — a shipped data set or the user's CSV file — with the model fitted
to it, every filter run over it and judged on its held-out tail (:ref:`data`).

Its inputs (keys ``data_…``, in links like every input): the data set (``data_set=nile``; ``upload`` for a file of
one's own, which a link cannot carry), the share of the times held out and the order m (0: chosen by BIC). An
uploaded file stays in the session's memory only (nothing is written to disk) and is dropped when the session
ends; it is refused beside the file input — over :data:`app.state.data_job.MAX_UPLOAD` before anything is parsed,
or as the core refuses it (non-numbers, times unsorted or repeated, empty, binary) — and nothing is fitted then.
Reading a file or a set is a job off the event loop; the fit (:func:`app.state.data_job.fit_series`) is the
session's long job (progress, cancel, the server's queue), started when the tab is open and the series, the
held-out share or m changes, or by the Fit button.
"""

from __future__ import annotations

from functools import partial
from typing import ClassVar

import param

from isl_core import M_MAX
from isl_core.series import DATASETS, Series

from ..inputs import Real, Whole
from ..jobs import Outcome
from .data_job import MAX_UPLOAD, DataResult, estimates_csv, fit_json, load, read_upload
from .room import LongJobRoom

__all__ = ["SOURCES", "DataRoom"]

SOURCES = (*DATASETS, "upload")  #: the data set input's choices: the shipped sets, and the user's own file


class DataRoom(LongJobRoom):
    """Inputs, series, fit and downloads of the "Your data" tab (the module docstring); keys ``data_…``."""

    KEYS: ClassVar[dict[str, str]] = {"data_set": "source", "data_holdout": "holdout", "data_m": "order"}

    source = param.Selector(
        objects=list(SOURCES),
        default="nile",
        label="data set",
        doc="A data set shipped with the packages (nile, co2, long), or upload for a CSV file of your own.",
    )
    holdout = Real(
        0.2,
        bounds=(0.05, 0.9),
        label="held-out share",
        doc="Share of the times at the end kept out of the fit: the filters are judged on them (0.05 to 0.9).",
    )

    order = Whole(
        0,
        bounds=(0, M_MAX),
        label="order m (0: by BIC)",
        doc="The model's order m, 1 to 6; 0 fits every m and keeps the one of least BIC (a long series: minutes).",
    )

    series = param.ClassSelector(class_=Series, default=None, allow_None=True, precedence=-1)
    result = param.ClassSelector(class_=DataResult, default=None, allow_None=True, precedence=-1)
    columns = param.List([], precedence=-1, doc="The uploaded file's columns (its header).")
    time_column = param.String("", precedence=-1)
    value_column = param.String("", precedence=-1)
    upload_note = param.String("", precedence=-1, doc="Why the uploaded file was refused (shown beside the input).")

    def __init__(self, host, **params) -> None:
        super().__init__(host, **params)
        self._wanted = False  # the series is read and fitted once the tab is open
        self._file: bytes | None = None  # the uploaded file, in this session's memory only
        self._file_name = ""
        self._reading = 0  # the newest read asked for: an older one's answer is dropped
        self._settling = False  # the room itself shows the uploaded file as the data set: nothing to read
        self._fitted: Series | None = None  # the series of the fit on screen
        self.param.watch(self._on_source, ["source"])
        self.param.watch(self._on_holdout, ["holdout", "order"])
        self._again = False  # a fit was asked for while another ran
        self.param.watch(self._on_busy, ["busy"])

    # ---- the series ------------------------------------------------------------------------------------
    def want(self) -> None:
        """The tab is on screen: read its series and fit it, now and whenever the inputs change."""
        if not self._wanted:
            self._wanted = True
            self._load()

    def _on_source(self, *events) -> None:
        if self._wanted and not self._settling:
            self._load()

    def _on_holdout(self, *events) -> None:
        if self.series is not None:  # a series on screen: fitted again with the new share
            self.fit()

    def _load(self) -> None:
        self._reading += 1
        if self.source == "upload":
            if self._file is None:
                self.param.update(series=None, result=None, note="Choose a CSV file to upload.")
            else:
                self._read(self.time_column or None, self.value_column or None)
            return
        serial = self._reading
        self.param.update(note=f"Reading the data set {self.source} …", upload_note="")
        self.jobs.submit("data-read", partial(load, self.source), partial(self._loaded, serial), pool="view")

    def _loaded(self, serial: int, outcome: Outcome, superseded: bool) -> None:
        if serial != self._reading or superseded:
            return
        if outcome.error is not None:
            self.param.update(
                series=None, result=None, note=f"Could not read the data set: {self.describe(outcome.error)}."
            )
            return
        self.series = outcome.value
        self.fit()

    def upload(self, data, filename: str = "") -> None:
        """A file chosen in the page: refused over the limit before anything is parsed, else read off the loop (its
        header's columns, the series of the first two) and fitted."""
        name = str(filename or "upload")[:80]
        size = len(data) if isinstance(data, bytes | bytearray) else None
        if size is None:
            self._refuse_file("the file could not be read (choose it again)")
            return
        if size > MAX_UPLOAD:
            self._refuse_file(f"{name} has {size:,} bytes, over the limit of {MAX_UPLOAD // 1_000_000} MB")
            return
        self._file, self._file_name = bytes(data), name
        self.param.update(columns=[], time_column="", value_column="")
        self._reading += 1
        self._read(None, None)

    def too_large(self, filename, size: str) -> None:
        """The browser did not send a file over the limit (:class:`app.views.file_picker.FilePicker`): refused in
        words."""
        name = str(filename or "the file")[:80]
        n = int(size) if str(size).isdigit() and len(str(size)) < 16 else None
        what = f"{n:,} bytes" if n is not None else "more"
        self._refuse_file(f"{name} has {what}, over the limit of {MAX_UPLOAD // 1_000_000} MB")

    def choose_columns(self, time: str, value: str) -> None:
        """The time and value columns of the uploaded file (from its header), then the series read again."""
        if self._file is None or (time, value) == (self.time_column, self.value_column):
            return
        self._reading += 1
        self._read(time or None, value or None)

    def _read(self, time: str | None, value: str | None) -> None:
        assert self._file is not None
        serial = self._reading
        self.note = f"Reading {self._file_name} …"
        fn = partial(read_upload, self._file, time, value, self._file_name)
        self.jobs.submit("data-read", fn, partial(self._read_done, serial), pool="view")

    def _read_done(self, serial: int, outcome: Outcome, superseded: bool) -> None:
        if serial != self._reading or superseded:
            return
        if outcome.error is not None:
            self._refuse_file(self.describe(outcome.error))
            return
        up = outcome.value
        self._settling = True
        try:
            self.source = "upload"  # the file is on screen now: the selector and the link follow, no second read
        finally:
            self._settling = False
        self.param.update(
            columns=list(up.columns),
            time_column=up.time or "",
            value_column=up.value or "",
            upload_note="",
            series=up.series,
        )
        self.fit()

    def _refuse_file(self, why: str) -> None:
        kept = " The fit on screen is kept." if self.result is not None else ""
        self.param.update(upload_note=f"Refused: {why}. Nothing was fitted.{kept}", note="")

    # ---- the fit ---------------------------------------------------------------------------------------
    def fit(self) -> None:
        """Fit the model to the series, run and judge every filter, as the session's long job."""
        if blocked := self.refused_among(self.KEYS):
            self.note = blocked
            return
        s = self.series
        if s is None:
            self.note = "Nothing to fit: choose a data set or upload a CSV file."
            return
        if self.busy:  # a fit of the series or share before runs: stopped, then this one starts (_on_busy)
            self._again = True
            self._task.cancel()
            return
        from .data_job import fit_series

        self._task.start(
            partial(fit_series, s, self.holdout, m=self.order or None),
            partial(self._apply, s),
            f"Fitting {f'm = {self.order}' if self.order else 'm = 1 … 6'} to {s.name} ({s.n:,} times), then every"
            " filter …",
        )

    def cancel(self) -> None:
        """Stop the fit: dropped if it waits in the queue, else ended."""
        self._again = False
        super().cancel()

    def _on_busy(self, event) -> None:
        if not event.new and self._again:  # the fit before has ended: the one asked for since starts, once the
            self._again = False  # end of the other has been shown
            self.later(self.fit)

    def _apply(self, series: Series, outcome: Outcome) -> None:
        res: DataResult = outcome.value
        f = res.summary["fit"]
        self._fitted = series
        self.param.update(
            result=res,
            note=(
                f"Fitted in {outcome.seconds:.1f} s on the first {res.summary['split']:,} of {res.n:,} times; "
                f"m = {f['m']}{' chosen by BIC' if res.summary['orders'] else ' given'}; the filters judged on the"
                " rest."
            ),
        )

    # ---- downloads ---------------------------------------------------------------------------------------
    def estimates_file(self) -> str:
        """Every filter's estimates at the fit on screen, as CSV (:func:`app.state.data_job.estimates_csv`)."""
        if self.result is None or self._fitted is None:
            return "# no fit to export\n"
        return estimates_csv(self._fitted, self.result)

    def fit_file(self) -> str:
        """The fit on screen as JSON (the command line's ``isl data --json``)."""
        return fit_json(self.result) if self.result is not None else "{}\n"

    def release(self) -> None:
        """The session ends: drop the file, the series and the fit without a redraw."""
        self._file = self._fitted = None
        with param.parameterized.discard_events(self):
            self.param.update(series=None, result=None, columns=[])
