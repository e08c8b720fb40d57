"""Origin checks and error pages of the served dashboard (``python -m app.serve`` on 127.0.0.1).

A browser on another site must not be able to open a dashboard session (websocket ``Origin`` check); no HTTP
answer, however malformed the request, may carry a Python traceback.
"""
from __future__ import annotations

import http.client
from urllib.parse import urlparse

import pytest
from _serving import load_test, run, served
from tornado.httpclient import HTTPClientError

MARKERS = load_test.TRACEBACK_MARKERS


@pytest.fixture(scope="module")
def default_server(tmp_path_factory):
    """The dashboard with the default origins; BOKEH_ALLOW_WS_ORIGIN=* in its environment must be ignored."""
    with served(tmp_path_factory.mktemp("origin"), "--stats-interval", "0",
                env={"ISL_ALLOWED_ORIGINS": "", "BOKEH_ALLOW_WS_ORIGIN": "*"}) as (url, _, log):
        yield url, log


def connect(url: str, origin: str):
    async def go():
        async with await load_test.BokehClient.connect(url, origin=origin, timeout=60) as client:
            return len(client.doc.roots)
    return run(go(), 120)


def refused(url: str, origin: str) -> bool:
    try:
        connect(url, origin)
    except HTTPClientError as exc:
        return exc.code == 403
    return False


def test_default_origins_admit_this_machine_only(default_server):
    url, log = default_server
    port = urlparse(url).port
    assert connect(url, f"http://localhost:{port}") > 0
    assert connect(url, f"http://127.0.0.1:{port}") > 0
    for origin in ("http://evil.example.com", f"http://evil.example.com:{port}", f"http://localhost:{port + 1}",
                   "null", f"http://127.0.0.1.evil.example.com:{port}"):
        assert refused(url, origin), origin
    text = log.read_text()
    assert "ignoring BOKEH_ALLOW_WS_ORIGIN" in text and "Refusing websocket connection" in text


def test_listed_origins_replace_the_defaults(tmp_path):
    with served(tmp_path, "--stats-interval", "0", env={"ISL_ALLOWED_ORIGINS": "class.example.edu:8443"}) as (url, _, _):
        assert connect(url, "https://class.example.edu:8443") > 0
        port = urlparse(url).port
        assert refused(url, f"http://localhost:{port}")
        assert refused(url, "https://class.example.edu:9999")
        assert refused(url, "https://evil.example.edu:8443")


PROBES = [
    ("GET", "/"), ("GET", "/app"), ("GET", "/liveness"), ("GET", "/liveness?endpoint=/app"),
    ("GET", "/liveness?endpoint=/nope"), ("GET", "/nope"), ("GET", "/app/ws"), ("GET", "/app/autoload.js"),
    ("GET", "/app/autoload.js?bokeh-autoload-element=x&bokeh-app-path=/app&bokeh-absolute-url=http://e"),
    ("GET", "/static/../../../../etc/passwd"), ("GET", "/static/js/nope.js"), ("GET", "/app?alpha=nan&sigma=%00"),
    ("GET", "/app?" + "x" * 6000), ("GET", "/%"), ("GET", "/app/%ZZ"), ("POST", "/app"), ("PUT", "/liveness"),
    ("DELETE", "/app"), ("GET", "/favicon.ico"), ("GET", "/admin"), ("GET", "/rest/session_info"),
]


@pytest.mark.parametrize("method, path", PROBES)
def test_no_http_answer_contains_a_traceback(default_server, method, path):
    url, _ = default_server
    parsed = urlparse(url)
    conn = http.client.HTTPConnection(parsed.hostname, parsed.port, timeout=60)
    try:
        conn.request(method, path, body=b"{not json" if method in ("POST", "PUT") else None,
                     headers={"Content-Type": "application/json"})
        response = conn.getresponse()
        body = response.read().decode("utf-8", "replace")
        headers = str(response.headers)
    finally:
        conn.close()
    for marker in MARKERS:
        assert marker not in body and marker not in headers, (method, path, response.status, body[:500])
    if path in ("/admin", "/rest/session_info"):
        assert response.status == 404                       # no admin panel, no session REST endpoint
