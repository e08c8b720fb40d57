#!/usr/bin/env python3
"""A scripted browser for the isl dashboard's server, and helpers to start, probe and stop one.

:class:`BokehClient` opens a bokeh session over the websocket exactly as a browser does (same ``Origin`` header,
same session token, same ``PULL-DOC`` / ``PATCH-DOC`` messages, a ``document_ready`` event after the pull), but
without rendering: it keeps its own copy of the document, so it sees every update the server sends, and it can
change widgets and fire events as a user would. Used by the load script (``scripts/load_test.py``), the classroom
benchmark and the serving tests. Starting and stopping a server: :mod:`server_control` (re-exported here).
"""

from __future__ import annotations

import asyncio
import contextlib
import random
import re
import sys
import time
from collections.abc import Callable
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
from server_control import (  # noqa: F401  (re-exported: the server's side, for the same users)
    LOOPBACK,
    REPO,
    SERVE_ENV,
    check_loopback,
    cmdline,
    descendants,
    free_port,
    rss_mb,
    server_processes,
    start_server,
    stop_server,
    wait_healthy,
)

DATA_EVENTS = {"ColumnDataChanged", "ColumnsStreamed", "ColumnsPatched"}
# A session opens in a few seconds of server CPU, one after another: a generous bound that only catches hangs.
CONNECT_TIMEOUT_S = 300.0
TRACEBACK_MARKERS = ("Traceback (most recent call last)", 'File "/', '.py", line ')


# ------------------------------------------------------------------------------------------------ protocol client
@dataclass
class Reply:
    """What the server sent back after one of our messages."""

    msgtype: str  # OK or ERROR
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
    light: bool = False  # record what each patch touches, do not apply it (a cheap load generator)
    _changed: asyncio.Event = field(default_factory=asyncio.Event)
    _reader: asyncio.Task | None = None
    _cds: set[str] | None = None

    @classmethod
    async def connect(
        cls,
        base_url: str,
        app_path: str = "/app",
        *,
        origin: str | None = None,
        timeout: float = 60.0,
        light: bool = False,
        query: str = "",
        host: str | None = None,
        token: str | None = None,
    ) -> BokehClient:
        """Open a session like a browser on ``base_url`` would, pull the document and announce it ready.

        ``light``: apply the server's later patches to ``doc`` except plot data (those go stale; ``patches`` still
        records every change) — one process can then drive a classroom.
        ``query``: the page's URL query (``"sigma=200&m=6"``), as a link would carry it. ``host``: the ``Host`` header
        (as a reverse proxy forwards the public name), default the URL's. ``token``: the session token of a page the
        server sent (:func:`page_token`), as the browser that loaded the page would send it; default a new session.
        """
        parsed = urlparse(base_url)
        token = token or generate_jwt_token(generate_session_id())
        ws_url = f"ws://{parsed.netloc}{app_path}/ws" + (f"?{query.lstrip('?')}" if query else "")
        request = HTTPRequest(
            ws_url,
            headers={"Origin": origin or f"http://{parsed.netloc}", **({"Host": host} if host else {})},
            connect_timeout=timeout,
            request_timeout=timeout,
        )
        socket = await websocket_connect(request, subprotocols=["bokeh", token], max_message_size=256 * 2**20)
        socket.protocol.set_nodelay(True)  # as browsers do: a message's frames leave at once, not after an ACK
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
                kept = [
                    e
                    for e in events
                    if e.get("kind") not in DATA_EVENTS
                    and not (e.get("kind") == "ModelChanged" and e.get("attr") == "data")
                ]
                if kept:
                    payload = Serialized({**message.content, "events": kept}, message.payload.buffers)
                    # UnknownReferenceError: it referred to a model only a skipped data change carried
                    with contextlib.suppress(UnknownReferenceError):
                        self.doc.apply_json_patch(payload, setter=self)
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

    def wake(self) -> None:
        """Have :meth:`wait_until` check its predicate now, not at the next message: something outside the session
        that the predicate reads has changed (a benchmark's stop)."""
        self._changed.set()

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

    def seen_since(self, t0: float, msgid: str | None = None) -> str:
        """What this client received after ``t0`` (and the server's answer to ``msgid``), in words: a diagnosis for a
        change that went unanswered — was it taken, did anything come back, and what."""
        names = {
            m.id: f"{type(m).__name__}({getattr(m, 'name', None) or getattr(m, 'title', None) or m.id})"
            for m in self.doc.models
        }
        after = [(t, kinds, models) for t, kinds, models in self.patches if t >= t0]
        touched = sorted({names.get(m, m) for _, _, models in after for m in models})
        reply = self.replies.get(msgid) if msgid is not None else None
        answer = "no reply" if reply is None else reply.msgtype + (f" {reply.text}" if reply.text else "")
        last = f"{self.patches[-1][0] - t0:+.1f} s" if self.patches else "none"
        return (
            f"server's answer to the change: {answer}; {len(after)} patch(es) since "
            f"({', '.join(sorted(set().union(*(k for _, k, _ in after)))) or 'none'}) touching "
            f"{', '.join(touched[:8]) or 'nothing'}{' …' if len(touched) > 8 else ''}; last patch at {last}; "
            f"closed={self.closed}, errors={self.errors[-1:] or 'none'}"
        )

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


async def page_token(base_url: str, app_path: str = "/app", query: str = "", timeout: float = 60.0) -> str:
    """Load the page as a browser would (``GET app_path``) and return the session token it carries."""
    from tornado.httpclient import AsyncHTTPClient

    url = f"{base_url}{app_path}" + (f"?{query.lstrip('?')}" if query else "")
    page = (await AsyncHTTPClient().fetch(url, request_timeout=timeout)).body.decode()
    found = re.search(r'"token":\s*"([^"]+)"', page)
    if found is None:
        raise RuntimeError(f"no session token in the page {url}")
    return found.group(1)


async def open_page(base_url: str, query: str = "", light: bool = False) -> BokehClient:
    """A session opened as a browser opens it: the page's HTML (:func:`page_token`), then its websocket."""
    token = await page_token(base_url, query=query, timeout=CONNECT_TIMEOUT_S)
    return await BokehClient.connect(base_url, query=query, token=token, light=light, timeout=CONNECT_TIMEOUT_S)
