"""The event loop's stalls, logged with where the loop's thread was (:mod:`app.serving.stalls`)."""

from __future__ import annotations

import asyncio
import logging
import threading
import time

from app.serving import stalls


def _hold_the_loop(seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:  # busy, as a long computation on the loop would be
        pass


class _Caught(logging.Handler):
    def __init__(self) -> None:
        super().__init__()
        self.records: list[logging.LogRecord] = []
        self.logged = threading.Event()

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)
        self.logged.set()


def test_a_stall_is_logged_with_its_length_and_where_the_loop_was():
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    caught = _Caught()
    stalls.log.addHandler(caught)
    try:
        thread.start()
        watcher = stalls.watch(loop, threshold=0.2)
        assert watcher is not None and stalls.watch(loop, threshold=0) is None
        loop.call_soon_threadsafe(_hold_the_loop, 0.05)  # too short to count
        loop.call_soon_threadsafe(_hold_the_loop, 0.4)
        assert caught.logged.wait(60), "no stall logged"
    finally:
        stalls.log.removeHandler(caught)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(10)
        loop.close()
    (record,) = caught.records
    stall = stalls.parse(record.getMessage())
    assert stall is not None and stall.ms >= 400 - 1e3 * stalls.BEAT_S, record.getMessage()
    assert "_hold_the_loop (test_stalls.py:" in stall.detail, stall.detail
    assert stalls.parse("isl stats: sessions=1") is None
