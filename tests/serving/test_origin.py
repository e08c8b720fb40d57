"""Origin and host checks, security headers and error pages of the served dashboard (``python -m app.serving``).

A browser on another site must not be able to open a dashboard session (websocket ``Origin`` check); a request
for another host name is refused (DNS rebinding); every answer carries the framing and sniffing headers; no HTTP
answer, however malformed the request, may carry a Python traceback.
"""

from __future__ import annotations

import http.client
import re
from urllib.parse import urlparse

import pytest
from _serving import run, served, session_client
from tornado.httpclient import HTTPClientError

MARKERS = session_client.TRACEBACK_MARKERS


@pytest.fixture(scope="module")
def default_server(tmp_path_factory):
    """The dashboard with the default origins; BOKEH_ALLOW_WS_ORIGIN=* in its environment must be ignored."""
    with served(
        tmp_path_factory.mktemp("origin"),
        "--stats-interval",
        "0",
        env={"ISL_ALLOWED_ORIGINS": "", "BOKEH_ALLOW_WS_ORIGIN": "*"},
    ) as (url, _, log):
        yield url, log


def connect(url: str, origin: str, host: str | None = None):
    async def go():
        async with await session_client.BokehClient.connect(url, origin=origin, timeout=60, host=host) as client:
            return len(client.doc.roots)

    return run(go(), 120)


def refused(url: str, origin: str, host: str | None = None) -> bool:
    try:
        connect(url, origin, host)
    except HTTPClientError as exc:
        return exc.code == 403
    return False


def get(url: str, path: str, **headers) -> tuple[int, dict, bytes]:
    parsed = urlparse(url)
    conn = http.client.HTTPConnection(parsed.hostname, parsed.port, timeout=60)
    try:
        conn.request("GET", path, headers=headers)
        r = conn.getresponse()
        return r.status, {k.lower(): v for k, v in r.getheaders()}, r.read()
    finally:
        conn.close()


def test_default_origins_admit_this_machine_only(default_server):
    url, log = default_server
    port = urlparse(url).port
    assert connect(url, f"http://localhost:{port}") > 0
    assert connect(url, f"http://127.0.0.1:{port}") > 0
    for origin in (
        "http://evil.example.com",
        f"http://evil.example.com:{port}",
        f"http://localhost:{port + 1}",
        "null",
        f"http://127.0.0.1.evil.example.com:{port}",
    ):
        assert refused(url, origin), origin
    text = log.read_text()
    assert "ignoring BOKEH_ALLOW_WS_ORIGIN" in text and "Refusing websocket connection" in text


def test_listed_origins_replace_the_defaults(tmp_path):
    public = "class.example.edu:8443"  # behind a reverse proxy that forwards the public Host name
    with served(tmp_path, "--stats-interval", "0", env={"ISL_ALLOWED_ORIGINS": public}) as (url, _, _):
        assert connect(url, "https://class.example.edu:8443", host=public) > 0
        port = urlparse(url).port
        assert refused(url, f"http://localhost:{port}", host=public)
        assert refused(url, "https://class.example.edu:9999", host=public)
        assert refused(url, "https://evil.example.edu:8443", host=public)
        assert refused(url, "https://class.example.edu:8443")  # the right origin, reached under another host name
        assert get(url, "/liveness")[0] == 200  # health probes come by IP: always answered


def test_other_host_names_are_refused_before_any_session_exists(default_server):
    url, _ = default_server
    port = urlparse(url).port
    for host in ("evil.example.com", f"evil.example.com:{port}", f"127.0.0.1.evil.example.com:{port}"):
        status, _, body = get(url, "/app", Host=host)
        assert status == 403 and b"does not answer to that host name" in body
    assert get(url, "/app", Host=f"localhost:{port}")[0] == 200


def test_answers_carry_the_framing_and_sniffing_headers_and_scripts_are_compressed(default_server):
    url, _ = default_server
    status, headers, page = get(url, "/app")
    assert status == 200
    assert headers["content-security-policy"] == "frame-ancestors 'self'"
    assert headers["x-frame-options"] == "SAMEORIGIN" and headers["x-content-type-options"] == "nosniff"
    assert headers["referrer-policy"] == "same-origin"
    script = "/" + next(s for s in re.findall(rb'src="([^"]+\.js[^"]*)"', page) if b"bokeh.min" in s).decode()
    status, _, plain = get(url, script)
    status_gz, headers, body = get(url, script, **{"Accept-Encoding": "gzip"})
    assert status == status_gz == 200 and headers.get("content-encoding") == "gzip"
    assert len(plain) > 500_000 and len(body) < len(plain) / 2, (len(plain), len(body))  # bokeh.min.js


def test_liveness_never_builds_a_session(default_server):
    """Panel's /liveness?endpoint=/app built a whole session on the event loop (1.2–1.8 s); this one answers only."""
    url, log = default_server
    before = log.read_text().count("Session")
    status, _, body = get(url, "/liveness?endpoint=/app")
    assert status == 200 and body == b'{"alive": true}'
    assert log.read_text().count("Session") == before


PROBES = [
    ("GET", "/"),
    ("GET", "/app"),
    ("GET", "/liveness"),
    ("GET", "/liveness?endpoint=/app"),
    ("GET", "/liveness?endpoint=/nope"),
    ("GET", "/nope"),
    ("GET", "/app/ws"),
    ("GET", "/app/autoload.js"),
    ("GET", "/app/autoload.js?bokeh-autoload-element=x&bokeh-app-path=/app&bokeh-absolute-url=http://e"),
    ("GET", "/static/../../../../etc/passwd"),
    ("GET", "/static/js/nope.js"),
    ("GET", "/app?alpha=nan&sigma=%00"),
    ("GET", "/app?" + "x" * 6000),
    ("GET", "/%"),
    ("GET", "/app/%ZZ"),
    ("POST", "/app"),
    ("PUT", "/liveness"),
    ("DELETE", "/app"),
    ("GET", "/favicon.ico"),
    ("GET", "/admin"),
    ("GET", "/rest/session_info"),
]


@pytest.mark.parametrize("method, path", PROBES)
def test_no_http_answer_contains_a_traceback(default_server, method, path):
    url, _ = default_server
    parsed = urlparse(url)
    conn = http.client.HTTPConnection(parsed.hostname, parsed.port, timeout=60)
    try:
        conn.request(
            method,
            path,
            body=b"{not json" if method in ("POST", "PUT") else None,
            headers={"Content-Type": "application/json"},
        )
        response = conn.getresponse()
        body = response.read().decode("utf-8", "replace")
        headers = str(response.headers)
    finally:
        conn.close()
    for marker in MARKERS:
        assert marker not in body and marker not in headers, (method, path, response.status, body[:500])
    if path in ("/admin", "/rest/session_info"):
        assert response.status == 404  # no admin panel, no session REST endpoint


def test_websocket_frames_leave_without_waiting_for_an_acknowledgement():
    """install() turns Nagle's algorithm off on every websocket connection it serves (bokeh writes a message as
    several small frames); the handler reports its own socket's TCP_NODELAY, read after the connection opened."""
    import asyncio
    import socket

    import tornado.httpserver
    import tornado.web
    import tornado.websocket

    from app.serving import webguard

    class Echo(tornado.websocket.WebSocketHandler):
        def on_message(self, message):
            sock = self.ws_connection.stream.socket
            self.write_message(str(sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)))

    async def probe() -> str:
        app = tornado.web.Application([(r"/ws", Echo)])
        webguard.install(app, ["127.0.0.1:*"], ["'self'"])
        server = tornado.httpserver.HTTPServer(app)
        port = session_client.free_port()
        server.listen(port, "127.0.0.1")
        try:
            conn = await tornado.websocket.websocket_connect(f"ws://127.0.0.1:{port}/ws")
            await conn.write_message("?")
            answer = await asyncio.wait_for(conn.read_message(), 30)
            conn.close()
            return answer
        finally:
            server.stop()

    assert run(probe(), 60) == "1"
