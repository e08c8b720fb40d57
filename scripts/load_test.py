#!/usr/bin/env python3
"""Classroom load test for the isl dashboard: many concurrent sessions moving a slider.

Each simulated student is one bokeh session opened over the websocket exactly as a browser opens it (same
``Origin`` header, same session token, same ``PULL-DOC`` / ``PATCH-DOC`` messages, a ``document_ready`` event
after the pull), but without rendering: the client keeps its own copy of the document, so it sees every update
the server sends. Every ``--interval`` seconds (±25 % jitter) each session sets a slider to a new value (``value``
and ``value_throttled``, as a released drag does) and measures the *update latency*: the time until the server's
first change to plot data (a ``ColumnDataSource``) arrives. An ``ERROR`` reply, a lost connection, or no update
within ``--update-timeout`` counts as an error.

Usage (the long classroom run: 100 sessions for 5 minutes, against a server this script starts):

    PYTHONPATH=. python scripts/load_test.py --sessions 100 --duration 300

the memory run (open and close 50 sessions three times; the server's RSS after each round):

    PYTHONPATH=. python scripts/load_test.py --memory 3 --sessions 50

or against a running server (``./scripts/serve`` or the container)::

    python scripts/load_test.py --url http://127.0.0.1:5006 --server-pid <pid> --sessions 100 --duration 300

It prints one line per figure: sessions held, errors, update latency (median, p95, max), the server's resident
memory before / with every session open, and RSS per session. Only loopback URLs are accepted. The test suite
(``tests/test_load.py``) runs a short version of the same function, :func:`run_load`.
"""
from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import re
import subprocess
import sys
import time
import urllib.request
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Self
from urllib.parse import urlparse

import panel  # noqa: F401  (registers Panel's bokeh models, so pulled documents deserialize)
from bokeh.core.serialization import Serialized, UnknownReferenceError
from bokeh.document import Document
from bokeh.document.events import MessageSentEvent, ModelChangedEvent
from bokeh.events import DocumentReady, Event
from bokeh.models import ColumnDataSource, Markup, Model, Slider
from bokeh.protocol import Protocol
from bokeh.protocol.receiver import Receiver
from bokeh.util.token import generate_jwt_token, generate_session_id
from tornado.httpclient import HTTPRequest
from tornado.websocket import websocket_connect

REPO = Path(__file__).resolve().parents[1]
LOOPBACK = {"127.0.0.1", "localhost", "::1"}
DATA_EVENTS = {"ColumnDataChanged", "ColumnsStreamed", "ColumnsPatched"}
# A session opens in a few seconds of server CPU, one after another: a generous bound that only catches hangs.
CONNECT_TIMEOUT_S = 300.0
TRACEBACK_MARKERS = ("Traceback (most recent call last)", 'File "/', ".py\", line ")


# ------------------------------------------------------------------------------------------------ protocol client
@dataclass
class Reply:
    """What the server sent back after one of our messages."""

    msgtype: str                       # OK or ERROR
    text: str = ""
    traceback: str | None = None


@dataclass
class BokehClient:
    """One dashboard session over a websocket, driven from an asyncio loop (no rendering)."""

    url: str
    doc: Document
    _socket: Any
    _receiver: Receiver
    _protocol: Protocol
    replies: dict[str, Reply] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)
    patches: list[tuple[float, set[str], set[str]]] = field(default_factory=list)  # (time, event kinds, models)
    closed: bool = False
    light: bool = False                # record what each patch touches, do not apply it (a cheap load generator)
    _changed: asyncio.Event = field(default_factory=asyncio.Event)
    _reader: asyncio.Task | None = None
    _cds: set[str] | None = None

    @classmethod
    async def connect(cls, base_url: str, app_path: str = "/app", *, origin: str | None = None,
                      timeout: float = 60.0, light: bool = False, query: str = "", host: str | None = None
                      ) -> BokehClient:
        """Open a session like a browser on ``base_url`` would, pull the document and announce it ready.

        ``light``: apply the server's later patches to ``doc`` except plot data (those go stale; ``patches`` still
        records every change) — one process can then drive a classroom.
        ``query``: the page's URL query (``"sigma=200&m=6"``), as a link would carry it. ``host``: the ``Host`` header
        (as a reverse proxy forwards the public name), default the URL's.
        """
        parsed = urlparse(base_url)
        session_id = generate_session_id()
        token = generate_jwt_token(session_id)
        ws_url = f"ws://{parsed.netloc}{app_path}/ws" + (f"?{query.lstrip('?')}" if query else "")
        request = HTTPRequest(ws_url, headers={"Origin": origin or f"http://{parsed.netloc}",
                                               **({"Host": host} if host else {})},
                              connect_timeout=timeout, request_timeout=timeout)
        socket = await websocket_connect(request, subprotocols=["bokeh", token], max_message_size=256 * 2**20)
        protocol = Protocol()
        client = cls(ws_url, Document(), socket, Receiver(protocol), protocol, light=light)
        try:
            await client._handshake(timeout)
        except BaseException:
            socket.close()
            raise
        return client

    async def _handshake(self, timeout: float) -> None:
        ack = await asyncio.wait_for(self._read(), timeout)
        if ack is None or ack.msgtype != "ACK":
            raise ConnectionError(f"expected ACK from {self.url}, got {ack!r}")
        await self._send(self._protocol.create("PULL-DOC-REQ"))
        early = []  # a session computes its first run off the event loop: its patches may overtake the reply
        while True:
            reply = await asyncio.wait_for(self._read(), timeout)
            if reply is None or reply.msgtype not in ("PULL-DOC-REPLY", "PATCH-DOC"):
                raise ConnectionError(f"expected PULL-DOC-REPLY from {self.url}, got {reply!r}")
            if reply.msgtype == "PULL-DOC-REPLY":
                break
            early.append(reply)
        reply.push_to_document(self.doc)  # a snapshot made after those patches: they are in it already
        for message in early:
            events = message.content.get("events", [])
            self.patches.append((time.perf_counter(), {e.get("kind", "") for e in events}, set()))
        self._reader = asyncio.ensure_future(self._read_forever())
        await self.send_event(DocumentReady())

    # -- sending
    async def _send(self, message: Any) -> str:
        from bokeh.client.websocket import WebSocketClientConnectionWrapper
        await message.send(WebSocketClientConnectionWrapper(self._socket))
        return message.header["msgid"]

    async def change(self, model: Model, **attrs: Any) -> tuple[str, float]:
        """Send one ``PATCH-DOC`` setting ``attrs`` on ``model``, unvalidated (a scripted client can send anything).

        Returns the message id and the time it was sent (``time.perf_counter``).
        """
        events = [ModelChangedEvent(self.doc, model, attr, value) for attr, value in attrs.items()]
        message = self._protocol.create("PATCH-DOC", events)
        sent_at = time.perf_counter()
        return await self._send(message), sent_at

    async def send_event(self, event: Event) -> str:
        """Send a UI event (``document_ready``, ``button_click`` …) as the browser does."""
        message = self._protocol.create("PATCH-DOC", [MessageSentEvent(self.doc, "bokeh_event", event)])
        return await self._send(message)

    # -- receiving
    async def _read(self) -> Any:
        while True:
            fragment = await self._socket.read_message()
            if fragment is None:
                return None
            message = await self._receiver.consume(fragment)
            if message is not None:
                return message

    async def _read_forever(self) -> None:
        try:
            while (message := await self._read()) is not None:
                self._handle(message)
        except Exception as exc:  # noqa: BLE001  (a broken stream is this session's error, not the runner's)
            self.errors.append(f"reader: {exc!r}")
        finally:
            self.closed = True
            self._changed.set()

    def _handle(self, message: Any) -> None:
        kind = message.msgtype
        if kind == "PATCH-DOC":
            events = message.content.get("events", [])
            kinds = {e.get("kind", "") for e in events}
            models = {str(e.get("model", {}).get("id", "")) for e in events if isinstance(e.get("model"), dict)}
            if not self.light:
                message.apply_to_document(self.doc, self)
            else:  # the page's structure (deferred widgets, new panes) but not the plots' data
                kept = [e for e in events if e.get("kind") not in DATA_EVENTS
                        and not (e.get("kind") == "ModelChanged" and e.get("attr") == "data")]
                if kept:
                    payload = Serialized({**message.content, "events": kept}, message.payload.buffers)
                    try:
                        self.doc.apply_json_patch(payload, setter=self)
                    except UnknownReferenceError:  # it referred to a model only a skipped data change carried
                        pass
                    self._cds = None  # new sources may have arrived
            self.patches.append((time.perf_counter(), kinds, models))
        elif kind in ("OK", "ERROR"):
            reply = Reply(kind, message.content.get("text", ""), message.content.get("traceback"))
            self.replies[message.header.get("reqid", "")] = reply
            if kind == "ERROR":
                self.errors.append(f"ERROR reply: {reply.text}")
        self._changed.set()

    async def wait_until(self, predicate: Callable[[], bool], timeout: float) -> bool:
        """Wait until ``predicate()`` holds (checked after every message) or ``timeout`` s pass."""
        deadline = time.perf_counter() + timeout
        while not predicate():
            if self.closed:
                return predicate()
            remaining = deadline - time.perf_counter()
            if remaining <= 0:
                return False
            self._changed.clear()
            try:
                await asyncio.wait_for(self._changed.wait(), remaining)
            except TimeoutError:
                return predicate()
        return True

    async def widgets(self, timeout: float = 120.0) -> bool:
        """Wait until the page's controls have arrived (the dashboard builds them after the page connects)."""
        return await self.wait_until(lambda: bool(sliders(self.doc)), timeout)

    async def reply_to(self, msgid: str, timeout: float) -> Reply | None:
        """The ``OK`` / ``ERROR`` answer to message ``msgid`` (None if none came in time)."""
        await self.wait_until(lambda: msgid in self.replies, timeout)
        return self.replies.get(msgid)

    def data_update_after(self, t0: float) -> float | None:
        """Time of the first plot-data change received after ``t0``."""
        cds = self._cds_ids()
        for t, kinds, models in self.patches:
            if t >= t0 and (kinds & DATA_EVENTS or models & cds):
                return t
        return None

    def _cds_ids(self) -> set[str]:
        if self.light and self._cds is not None:
            return self._cds
        self._cds = {m.id for m in self.doc.models if isinstance(m, ColumnDataSource)}
        return self._cds

    async def __aenter__(self) -> Self:
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        await self.close()

    async def close(self) -> None:
        self._socket.close()
        if self._reader is not None:
            try:
                await asyncio.wait_for(self._reader, 10)
            except TimeoutError:
                self._reader.cancel()


# --------------------------------------------------------------------------------------------- finding widgets
def sliders(doc: Document) -> list[Model]:
    """Every single-value slider in the document."""
    return [m for m in doc.models if isinstance(m, Slider)]


def find_slider(doc: Document, pattern: str = "") -> Model:
    """The first slider whose title or name matches the regular expression ``pattern``."""
    regex = re.compile(pattern, re.IGNORECASE)
    for model in sorted(sliders(doc), key=lambda m: str(m.id)):
        if regex.search(model.title or "") or (model.name and regex.search(model.name)):
            return model
    titles = [getattr(m, "title", "") for m in sliders(doc)]
    raise LookupError(f"no slider matches {pattern!r}; sliders: {titles}")


def notifications(doc: Document) -> list[str]:
    """Messages of Panel's notifications (toasts) in a client's copy of the document."""
    return [m.message for m in doc.models if type(m).__name__ == "Notification"]


def markup_texts(doc: Document) -> list[str]:
    """Texts of the HTML/Markdown panes (status lines, tables) in a client's copy of the document."""
    return [m.text for m in doc.models if isinstance(m, Markup)]


def new_value(slider: Model, rng: random.Random, last: float | None = None) -> float:
    """A value inside the slider's range, on its step grid, at least two steps from ``last`` (default: the
    slider's value) — so that it is a real change even after the app rounds it."""
    start, end, step = float(slider.start), float(slider.end), float(getattr(slider, "step", 0) or 0)
    last = float(slider.value) if last is None else last
    for _ in range(100):
        value = rng.uniform(start, end)
        if step > 0:
            value = start + round((value - start) / step) * step
        if abs(value - last) >= 2 * max(step, 1e-9 * (end - start)):
            return type(slider.value)(value) if isinstance(slider.value, int) else value
    return end if abs(end - last) > abs(start - last) else start


# ------------------------------------------------------------------------------------------------ server helpers
def check_loopback(url: str) -> None:
    host = urlparse(url).hostname or ""
    if host not in LOOPBACK:
        raise SystemExit(f"load tests run against loopback only, got {url}")


def rss_mb(pid: int) -> float:
    """Resident memory of process ``pid`` and its descendants in MB (Linux ``/proc``; ``--num-procs`` forks)."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    total, todo = 0.0, [pid]
    while todo:
        p = todo.pop()
        todo += children.get(p, [])
        try:
            with open(f"/proc/{p}/status") as f:
                total += next(int(line.split()[1]) for line in f if line.startswith("VmRSS:")) / 1024
        except (OSError, StopIteration):
            continue
    return total


def free_port() -> int:
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_healthy(port: int, timeout: float, proc: subprocess.Popen | None = None) -> float:
    """Seconds until ``/liveness`` answers 200; raises if the server exits or ``timeout`` passes."""
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < timeout:
        if proc is not None and proc.poll() is not None:
            raise RuntimeError(f"server exited with code {proc.returncode} before it was healthy")
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/liveness", timeout=2) as r:
                if r.status == 200:
                    return time.perf_counter() - t0
        except OSError:
            pass
        time.sleep(0.1)
    raise TimeoutError(f"server on port {port} not healthy after {timeout} s")


def start_server(port: int, log_path: Path, extra: Iterable[str] = (), env: dict | None = None,
                 script: str | None = None) -> subprocess.Popen:
    """Start ``python -m app.serve`` on 127.0.0.1:``port`` (optionally serving another app ``script``)."""
    code = ("import sys, app.serve as s\n"
            + (f"s.app_script = lambda: {script!r}\n" if script else "")
            + "sys.exit(s.main(sys.argv[1:]))")
    full_env = {**os.environ, "PYTHONPATH": f"{REPO}{os.pathsep}{os.environ.get('PYTHONPATH', '')}", **(env or {})}
    with open(log_path, "w") as log:                       # the child keeps its own descriptor
        return subprocess.Popen([sys.executable, "-c", code, "--address", "127.0.0.1", "--port", str(port), *extra],
                                stdout=log, stderr=subprocess.STDOUT, env=full_env, cwd=REPO)


def stop_server(proc: subprocess.Popen, timeout: float = 15.0) -> int:
    """SIGTERM, then SIGKILL after ``timeout``; the exit code."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return proc.returncode


# -------------------------------------------------------------------------------------------------------- load
@dataclass
class LoadResult:
    sessions: int                      # sessions that connected
    held: int                          # sessions still connected with zero errors at the end
    updates: int
    errors: list[str]
    latencies: list[float]             # seconds, one per slider change that got its update
    rss_before_mb: float
    rss_loaded_mb: float               # all sessions open, before the slider changes
    rss_peak_mb: float = float("nan")  # sampled every 5 s while the sliders move
    rss_end_mb: float = float("nan")   # when the last change was answered

    def p(self, q: float) -> float:
        if not self.latencies:
            return float("nan")
        data = sorted(self.latencies)
        return data[min(len(data) - 1, int(q * len(data)))]

    @property
    def rss_per_session_mb(self) -> float:
        return (self.rss_loaded_mb - self.rss_before_mb) / max(self.sessions, 1)

    def report(self) -> str:
        return "\n".join([
            f"sessions connected        {self.sessions}",
            f"sessions held, 0 errors   {self.held}",
            f"slider updates            {self.updates}",
            f"errors                    {len(self.errors)}" + (f"  (first: {self.errors[0]})" if self.errors else ""),
            f"update latency median     {1000 * self.p(0.5):.0f} ms",
            f"update latency p95        {1000 * self.p(0.95):.0f} ms",
            f"update latency max        {1000 * self.p(1.0):.0f} ms",
            f"server RSS before         {self.rss_before_mb:.0f} MB",
            f"server RSS, all open      {self.rss_loaded_mb:.0f} MB",
            f"RSS per session           {self.rss_per_session_mb:.1f} MB",
            f"server RSS, peak / end    {self.rss_peak_mb:.0f} MB / {self.rss_end_mb:.0f} MB (sliders moving)",
        ])


async def _student(base_url: str, index: int, slider_pattern: str, duration: float, interval: float,
                   update_timeout: float, opened: asyncio.Event, all_open: asyncio.Event,
                   out: dict[int, tuple[BokehClient | None, list[float], list[str]]]) -> None:
    rng = random.Random(index)
    latencies: list[float] = []
    errors: list[str] = []
    out[index] = (None, latencies, errors)
    try:
        client = await BokehClient.connect(base_url, light=True, timeout=CONNECT_TIMEOUT_S)
    except Exception as exc:  # noqa: BLE001  (a refused or failed session is counted, not raised)
        errors.append(f"connect: {exc!r}")
        opened.set()
        return
    out[index] = (client, latencies, errors)
    if not await client.widgets():
        errors.append("no controls arrived within 120 s")
    opened.set()
    await all_open.wait()
    deadline = time.perf_counter() + duration
    await asyncio.sleep(rng.uniform(0, interval))
    last = None
    while time.perf_counter() < deadline and not client.closed:
        try:
            slider = find_slider(client.doc, slider_pattern)
            value = last = new_value(slider, rng, last)
            _, t0 = await client.change(slider, value=value, value_throttled=value)
            if await client.wait_until(lambda t0=t0: client.data_update_after(t0) is not None, update_timeout):
                latencies.append(client.data_update_after(t0) - t0)
            else:
                errors.append(f"no plot update within {update_timeout} s (closed={client.closed})")
        except Exception as exc:  # noqa: BLE001  (one student's failure is counted, the others go on)
            errors.append(f"session {index}: {exc!r}")
            break
        await asyncio.sleep(interval * rng.uniform(0.75, 1.25))
    if client.closed:
        errors.append("connection lost")


async def run_load(base_url: str, *, sessions: int, duration: float, interval: float = 3.0,
                   slider: str = "", server_pid: int | None = None, update_timeout: float = 30.0,
                   connect_batch: int = 10) -> LoadResult:
    """Open ``sessions`` sessions (``connect_batch`` at a time), then move ``slider`` in each for ``duration`` s."""
    check_loopback(base_url)
    rss = (lambda: rss_mb(server_pid)) if server_pid else (lambda: float("nan"))
    rss_before = rss()
    out: dict[int, tuple[BokehClient | None, list[float], list[str]]] = {}
    all_open = asyncio.Event()
    tasks = []
    for first in range(0, sessions, connect_batch):
        events = []
        for i in range(first, min(first + connect_batch, sessions)):
            events.append(opened := asyncio.Event())
            tasks.append(asyncio.ensure_future(_student(base_url, i, slider, duration, interval, update_timeout,
                                                        opened, all_open, out)))
        await asyncio.gather(*(e.wait() for e in events))
    rss_loaded = rss()
    all_open.set()
    peak = [rss_loaded]

    async def sample() -> None:
        while True:
            await asyncio.sleep(5.0)
            peak.append(rss())

    sampler = asyncio.ensure_future(sample())
    await asyncio.gather(*tasks)
    sampler.cancel()
    rss_end = rss()
    clients = [c for c, _, _ in out.values() if c is not None]
    errors = [e for _, _, errs in out.values() for e in errs] + [e for c in clients for e in c.errors]
    held = sum(1 for c, _, errs in out.values() if c is not None and not c.closed and not errs and not c.errors)
    latencies = [x for _, lat, _ in out.values() for x in lat]
    await asyncio.gather(*(c.close() for c in clients))
    return LoadResult(len(clients), held, len(latencies), errors, latencies, rss_before, rss_loaded,
                      max(peak + [rss_end]), rss_end)


# ------------------------------------------------------------------------------------------------------ memory
STATS = re.compile(r"isl stats: sessions=(\d+) connections=(\d+) pending_releases=(\d+) rss_mb=([\d.]+)")


def server_stats(log_path: Path) -> list[tuple[int, int, int, float]]:
    """Every ``isl stats`` line the server has logged so far (``--stats-interval``)."""
    return [(int(a), int(b), int(c), float(d)) for a, b, c, d in STATS.findall(log_path.read_text())]


@dataclass
class MemoryRound:
    rss_before_mb: float
    live_open: int                     # sessions the server reported with all of the round's sessions open
    rss_open_mb: float                 # all sessions of the round open and idle
    rss_after_mb: float                # all closed, destroyed by the server, garbage collected
    live_after: int                    # sessions the server still holds after the round
    pending_after: int                 # of which release hooks have not run


async def _wait_idle(client: BokehClient, quiet_s: float = 1.0, limit: float = 60.0) -> None:
    deadline = time.perf_counter() + limit
    while time.perf_counter() < deadline:
        count = len(client.patches)
        await asyncio.sleep(quiet_s)
        if len(client.patches) == count:
            return


async def memory_round(base_url: str, server_pid: int, log_path: Path, sessions: int, *, batch: int = 5,
                       release_timeout: float = 120.0) -> MemoryRound:
    """Open ``sessions`` sessions, let them settle, close them, wait until the server has destroyed them."""
    check_loopback(base_url)
    rss_before = rss_mb(server_pid)
    clients: list[BokehClient] = []
    for first in range(0, sessions, batch):
        clients += await asyncio.gather(*(BokehClient.connect(base_url) for _ in range(min(batch, sessions - first))))
    await asyncio.gather(*(_wait_idle(c) for c in clients))
    rss_open = rss_mb(server_pid)
    live_open = await _next_stats(log_path)
    await asyncio.gather(*(c.close() for c in clients))
    del clients
    seen = len(server_stats(log_path))
    deadline = time.perf_counter() + release_timeout
    live = pending = -1
    while time.perf_counter() < deadline:
        stats = server_stats(log_path)
        if len(stats) > seen:
            live, _, pending, _ = stats[-1]
            if live == 0 and pending == 0:
                break
            seen = len(stats)
        await asyncio.sleep(0.2)
    await asyncio.sleep(TRIM_INTERVAL_S + 1.0)    # the server hands freed memory back (app.serve.MemoryTrimmer)
    return MemoryRound(rss_before, live_open, rss_open, rss_mb(server_pid), live, pending)


async def _next_stats(log_path: Path, timeout: float = 30.0) -> int:
    """Live sessions in the next ``isl stats`` line the server logs."""
    seen = len(server_stats(log_path))
    deadline = time.perf_counter() + timeout
    while time.perf_counter() < deadline:
        stats = server_stats(log_path)
        if len(stats) > seen:
            return stats[-1][0]
        await asyncio.sleep(0.1)
    return -1


def memory_report(rounds: list[MemoryRound], sessions: int) -> str:
    first = rounds[0].rss_after_mb
    lines = [f"round {i + 1}: RSS {r.rss_before_mb:.0f} MB → {r.rss_open_mb:.0f} MB with {r.live_open} open → "
             f"{r.rss_after_mb:.0f} MB after closing ({r.live_after} sessions left, {r.pending_after} unreleased); "
             f"per idle session {(r.rss_open_mb - r.rss_before_mb) / sessions:.1f} MB"
             for i, r in enumerate(rounds)]
    drift = max(r.rss_after_mb for r in rounds[1:]) / first - 1 if len(rounds) > 1 else 0.0
    lines.append(f"RSS drift after round 1: {100 * drift:+.1f} % (limit +10 %)")
    return "\n".join(lines)


TRIM_INTERVAL_S = 5.0                             # app.serve.TRIM_INTERVAL_MS
MEMORY_SERVER_ARGS = ["--unused-session-lifetime", "1000", "--check-unused-sessions", "500", "--stats-interval", "500"]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--url", help="a running server (loopback); default: start one on a free port")
    p.add_argument("--server-pid", type=int, help="pid of that server, for its RSS")
    p.add_argument("--sessions", type=int, default=100)
    p.add_argument("--duration", type=float, default=300.0, help="seconds of slider changes")
    p.add_argument("--interval", type=float, default=3.0, help="seconds between one session's changes")
    p.add_argument("--slider", default="", help="regular expression for the slider's title (default: first)")
    p.add_argument("--num-threads", type=int, default=4, help="worker threads of the server started here")
    p.add_argument("--num-procs", type=int, default=1, help="worker processes of the server started here")
    p.add_argument("--json", action="store_true", help="print the figures as JSON too")
    p.add_argument("--memory", type=int, metavar="ROUNDS",
                   help="instead: open and close --sessions sessions ROUNDS times and report the server's RSS "
                        "(starts its own server)")
    opts = p.parse_args(argv)
    if opts.memory:
        return memory_main(opts.sessions, opts.memory)
    proc = None
    url, pid = opts.url, opts.server_pid
    if url is None:
        port = free_port()
        log_path = Path(os.environ.get("TMPDIR", "/tmp")) / f"isl-load-{port}.log"
        proc = start_server(port, log_path, ["--num-threads", str(opts.num_threads),
                                             "--num-procs", str(opts.num_procs)])
        startup = wait_healthy(port, 180, proc)
        print(f"server started in {startup:.1f} s (log: {log_path})", flush=True)
        url, pid = f"http://127.0.0.1:{port}", proc.pid
    try:
        result = asyncio.run(run_load(url, sessions=opts.sessions, duration=opts.duration, interval=opts.interval,
                                      slider=opts.slider, server_pid=pid))
    finally:
        if proc is not None:
            stop_server(proc)
    print(result.report())
    if opts.json:
        print(json.dumps({"sessions": result.sessions, "held": result.held, "updates": result.updates,
                          "errors": len(result.errors), "p50_ms": 1000 * result.p(0.5),
                          "p95_ms": 1000 * result.p(0.95), "rss_per_session_mb": result.rss_per_session_mb}))
    return 0 if not result.errors and result.held == opts.sessions else 1


def memory_main(sessions: int, rounds: int) -> int:
    port = free_port()
    log_path = Path(os.environ.get("TMPDIR", "/tmp")) / f"isl-memory-{port}.log"
    proc = start_server(port, log_path, MEMORY_SERVER_ARGS)
    try:
        wait_healthy(port, 180, proc)
        results = []
        for i in range(rounds):
            t0 = time.perf_counter()
            results.append(asyncio.run(memory_round(f"http://127.0.0.1:{port}", proc.pid, log_path, sessions)))
            print(f"round {i + 1} done in {time.perf_counter() - t0:.0f} s", flush=True)
    finally:
        stop_server(proc)
    print(memory_report(results, sessions))
    first = results[0].rss_after_mb
    ok = all(r.live_after == 0 and r.pending_after == 0 for r in results) and \
        all(r.rss_after_mb <= 1.10 * first for r in results[1:])
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
