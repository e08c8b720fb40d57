"""The event loop's stalls, logged with where the loop's thread was (:mod:`app.serving.stalls`), and the static files
compressed once on a thread (:mod:`app.serving.static`)."""

from __future__ import annotations

import asyncio
import gzip
import logging
import sys
import threading
import time
import types

import pytest
import tornado.web
from tornado.httpclient import AsyncHTTPClient

from app.serving import stalls, static


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


def test_the_threads_named_beside_a_stall_are_those_not_waiting():
    stop, waiting = threading.Event(), threading.Event()
    busy = threading.Thread(target=lambda: [_hold_the_loop(0.01) for _ in iter(stop.is_set, True)], name="spinning")
    idle = threading.Thread(target=waiting.wait, name="waiting")
    busy.start(), idle.start()
    named: list[str] = []
    try:  # sampled until the spinning thread is seen inside its work (not between two calls of it)
        for _ in range(1000):
            named += stalls._busy(sys._current_frames())
            if any("_hold_the_loop (test_stalls.py:" in n for n in named):
                break
            time.sleep(0.001)
    finally:
        stop.set(), waiting.set()
        busy.join(10), idle.join(10)
    assert any(n.startswith("spinning: ") and "_hold_the_loop (test_stalls.py:" in n for n in named), named
    assert not any(n.startswith("waiting: ") for n in named), named


@pytest.fixture
def static_server(tmp_path):
    """A tornado application serving ``tmp_path`` as the dashboard's server does (the compressing transform),
    with :func:`app.serving.static.install`; yields ``(fetch, the folder)``; ``fetch(name, **headers)``."""
    app = tornado.web.Application(
        [(r"/s/(.*)", tornado.web.StaticFileHandler, {"path": str(tmp_path)})],
        transforms=[tornado.web.GZipContentEncoding],
    )
    static.install(app)
    static.install(app)  # idempotent
    loop = asyncio.new_event_loop()

    async def start():
        server = app.listen(0, "127.0.0.1")
        return server, next(iter(server._sockets.values())).getsockname()[1]

    server, port = loop.run_until_complete(start())

    def fetch(name: str, **headers):
        async def go():
            client = AsyncHTTPClient()
            return await client.fetch(
                f"http://127.0.0.1:{port}/s/{name}", headers=headers, decompress_response=False, raise_error=False
            )

        return loop.run_until_complete(go())

    yield fetch, tmp_path
    server.stop()
    loop.close()


def test_static_files_are_compressed_once_on_a_thread(static_server, monkeypatch):
    fetch, folder = static_server
    threads = []
    compress = static._compress
    monkeypatch.setattr(
        static, "_compress", lambda path: threads.append(threading.current_thread().name) or compress(path)
    )
    body = b"var x = 1;\n" * 20_000
    (folder / "a.js").write_bytes(body)
    first, second = fetch("a.js", **{"Accept-Encoding": "gzip"}), fetch("a.js", **{"Accept-Encoding": "gzip"})
    for answer in (first, second):
        assert answer.code == 200 and answer.headers["Content-Encoding"] == "gzip"
        assert gzip.decompress(answer.body) == body  # compressed once, not again by the transform
        assert answer.headers["Content-Length"] == str(len(answer.body))
    assert threads == ["isl-static_0"]  # made once, on the pool's thread, then kept
    assert fetch("a.js", **{"If-None-Match": first.headers["Etag"], "Accept-Encoding": "gzip"}).code == 304
    plain = fetch("a.js")  # no Accept-Encoding: the file as it is
    assert plain.code == 200 and "Content-Encoding" not in plain.headers and plain.body == body
    part = fetch("a.js", Range="bytes=0-9", **{"Accept-Encoding": "gzip"})
    assert part.code == 206 and gzip.decompress(part.body) == body[:10]  # a part: by the transform, as before
    changed = b"let y = 2;\n" * 30_000
    (folder / "a.js").write_bytes(changed)  # a new size: compressed again
    assert gzip.decompress(fetch("a.js", **{"Accept-Encoding": "gzip"}).body) == changed
    assert len(threads) == 2
    assert fetch("../outside.js", **{"Accept-Encoding": "gzip"}).code in (403, 404)


def test_where_names_the_frames_up_to_the_first_object_that_is_not_a_frame():
    """Another thread's stack read while it runs gave a ``cell`` as a frame's ``f_back`` once (CPython 3.11): the
    watcher named no stall and logged a traceback instead. The walk now ends there."""
    here = stalls._where(sys._getframe(), depth=1, callers=0)
    assert here.startswith("test_where_names_the_frames_up_to_the_first_object_that_is_not_a_frame (test_stalls.py:")
    assert stalls._where(types.CellType(), depth=1, callers=0) == ""
