"""The serve entry point (app.serving.serve) and the server-side hardening (app.serving.hardening)."""

from __future__ import annotations

import argparse
import logging
import os
import re
import resource
import signal
import subprocess
import sys

import panel as pn
import param
import pytest
from _serving import REPO, fixture_app, run, served, session_client, wait_for_log
from bokeh.document import Document
from bokeh.events import ButtonClick
from bokeh.models import Button
from bokeh.protocol import Protocol
from panel.command.serve import Serve

from app.serving import hardening, serve, session
from app.serving import options as cli_options


def panel_args(argv: list[str]) -> argparse.Namespace:
    """Parse with the installed Panel's own ``serve`` parser: every flag we build must be one it knows."""
    parser = argparse.ArgumentParser()
    Serve(parser=parser)
    return parser.parse_args(argv)


def options(*argv: str) -> argparse.Namespace:
    return cli_options.build_parser().parse_args(list(argv))


@pytest.fixture
def clean_env(monkeypatch):
    for name in [*cli_options.ENV.values(), serve.BOKEH_ORIGIN_ENV]:
        monkeypatch.delenv(name, raising=False)
    return monkeypatch


# ------------------------------------------------------------------------------------------------ origins
def test_default_origins_are_this_machine_only():
    assert serve.allowed_origins(5006, None) == ["localhost:5006", "127.0.0.1:5006"]
    assert serve.allowed_origins(8080, " , ") == ["localhost:8080", "127.0.0.1:8080"]


def test_origins_from_environment_and_flags_without_duplicates():
    got = serve.allowed_origins(5006, "class.example.edu:5006, 10.0.0.7:5006", ["class.example.edu:5006", "x:1"])
    assert got == ["class.example.edu:5006", "10.0.0.7:5006", "x:1"]


@pytest.mark.parametrize("bad", ["*", "*:5006", "*.*", "http://host:5006", "host/path", ":5006", "host:port"])
def test_wildcard_and_malformed_origins_are_refused(bad):
    with pytest.raises(ValueError, match="websocket origin"):
        serve.allowed_origins(5006, bad)


def test_bad_origin_environment_exits_with_usage_error(clean_env):
    clean_env.setenv(cli_options.ENV["origins"], "*")
    assert serve.main(["--health", "--port", "1"]) == 2


# ---------------------------------------------------------------------------------------------- arguments
def test_panel_arguments_are_the_safe_defaults(clean_env):
    opts = options()
    argv = serve.panel_argv(opts, "app.py", serve.allowed_origins(opts.port, None))
    args = panel_args(argv)
    assert (args.address, args.port) == (cli_options.DEFAULT_ADDRESS, cli_options.DEFAULT_PORT)
    # /liveness is app.serving.webguard's: Panel's builds a session for ?endpoint=
    assert args.warm and not args.liveness
    assert not args.admin and not args.dev and not args.autoreload
    assert args.allow_websocket_origin == ["localhost:5006", "127.0.0.1:5006"]
    assert (
        args.num_threads == cli_options.DEFAULT_NUM_THREADS and args.num_procs == 0
    )  # one per core (app.serving.workers)
    assert args.reuse_sessions  # a page's HTML does not build it: its websocket does, in the process it reaches
    assert args.unused_session_lifetime == cli_options.UNUSED_SESSION_LIFETIME_MS
    assert args.check_unused_sessions == cli_options.CHECK_UNUSED_SESSIONS_MS
    assert args.websocket_max_message_size == serve.WEBSOCKET_MAX_MESSAGE_BYTES
    assert "*" not in " ".join(argv)


def test_environment_configures_a_container(clean_env):
    clean_env.setenv("ISL_ADDRESS", "0.0.0.0")
    clean_env.setenv("ISL_PORT", "7000")
    clean_env.setenv("ISL_NUM_PROCS", "2")
    clean_env.setenv("ISL_NUM_THREADS", "8")
    opts = options()
    args = panel_args(serve.panel_argv(opts, "app.py", ["lab.example.edu:7000"]))
    assert (args.address, args.port, args.num_procs, args.num_threads) == ("0.0.0.0", 7000, 2, 8)
    assert args.allow_websocket_origin == ["lab.example.edu:7000"]
    assert options("--port", "7100").port == 7100  # a flag beats the environment


@pytest.mark.parametrize(
    "argv",
    [
        ["--port", "0"],
        ["--port", "70000"],
        ["--num-threads", "0"],
        ["--num-procs", "-1"],
        ["--unused-session-lifetime", "0"],
        ["--stats-interval", "-5"],
    ],
)
def test_out_of_range_counts_are_usage_errors(clean_env, argv, caplog):
    with caplog.at_level(logging.ERROR, logger="isl.serve"):
        assert serve.main([*argv, "--health"]) == 2
    assert argv[0] in caplog.text


def test_non_integer_environment_is_a_clear_error(clean_env):
    clean_env.setenv("ISL_PORT", "50o6")
    with pytest.raises(SystemExit, match="ISL_PORT must be an integer"):
        options()


@pytest.mark.parametrize(
    "address, url",
    [
        ("0.0.0.0", "http://localhost:5006/"),
        ("127.0.0.1", "http://localhost:5006/"),
        ("192.168.1.20", "http://192.168.1.20:5006/"),
    ],
)
def test_printed_url(address, url):
    assert serve.browser_url(address, 5006) == url


def test_app_script_is_found_in_the_package_without_running_it():
    path = serve.app_script()
    assert path.endswith("app.py") and "app" in path.split("/")[-2]


def test_health_of_a_closed_port_is_failure(clean_env):
    assert serve.main(["--health", "--port", str(session_client.free_port())]) == 1


# ---------------------------------------------------------------------------------------------- hardening
def test_exception_handler_logs_traceback_and_never_raises(caplog):
    try:
        raise RuntimeError("internal detail")
    except RuntimeError as exc:
        error = exc
    with caplog.at_level(logging.ERROR, logger="isl.app"):
        session.handle_exception(error)
    record = caplog.records[-1]
    assert re.search(r"incident [0-9a-f]{8}", record.getMessage())
    assert record.exc_info[1] is error  # the traceback goes to the server log


def test_install_is_idempotent():
    hardening.install()
    hardening.install()
    assert pn.config.exception_handler is session.handle_exception
    assert pn.config.notifications is True


class _Sink:
    """What bokeh's websocket handler's ``send_message`` is given to call last: it keeps the messages sent."""

    def __init__(self, application, request) -> None:
        self.sent: list = []

    async def send_message(self, message) -> None:
        self.sent.append(message)


def test_websocket_error_replies_carry_no_traceback_and_no_internal_text(caplog):
    """bokeh's ERROR reply carries the exception's text and the server's traceback; the server's handlers (bokeh's,
    subclassed: no library code replaced) send a validation error's text alone and any other as an incident number,
    whose text and traceback go to the log. Other messages pass as they are."""
    import asyncio

    import tornado.routing
    import tornado.web
    import tornado.websocket

    class Handler(_Sink, tornado.websocket.WebSocketHandler):
        pass

    application = tornado.web.Application([(r"/ws", Handler)])
    hardening.quiet_error_replies(application)
    hardening.quiet_error_replies(application)  # idempotent
    quiet = application.wildcard_router.rules[0].target
    assert issubclass(quiet, Handler) and quiet.__bases__ == (Handler,)
    protocol = Protocol()
    try:
        raise ValueError("failed to validate Slider(id='p1', ...).value: expected a value of type Real, got abc")
    except ValueError as exc:
        validation = protocol.create("ERROR", "m1", repr(exc))
    try:
        raise RuntimeError("SECRET-DETAIL in /srv/private/config.py")
    except RuntimeError as exc:
        internal = protocol.create("ERROR", "m2", repr(exc))
    assert validation.content["traceback"] and internal.content["traceback"]  # bokeh's own: what is withheld
    other = protocol.create("ACK")
    handler = quiet(application, None)
    with caplog.at_level(logging.ERROR, logger="isl.app"):
        for message in (validation, internal, other):
            asyncio.run(handler.send_message(message))
    assert handler.sent == [validation, internal, other]
    assert validation.content == {
        "text": repr(
            ValueError("failed to validate Slider(id='p1', ...).value: expected a value of type Real, got abc")
        ),
        "traceback": None,
    }
    assert internal.content["traceback"] is None and "SECRET" not in internal.content["text"]
    assert "SECRET" not in internal.content_json and "Traceback" not in internal.content_json  # what is sent
    incident = re.search(r"incident ([0-9a-f]{8})", internal.content["text"]).group(1)
    assert f"incident {incident}" in caplog.text and "SECRET-DETAIL" in caplog.text and "Traceback" in caplog.text
    assert other.content == {}


def test_no_stylesheet_of_a_page_points_at_panels_cdn():
    """Panel points the stylesheets of a part built for a document it has not rendered yet (a page being built, the
    warm-up's) at its CDN, and a classroom without internet waited on that request (a part shown loading asked for
    ``loading.css``); with the server's own files named first, no stylesheet of the page points elsewhere."""
    from bokeh.models import ImportedStyleSheet
    from panel.io.resources import CDN_DIST
    from panel.io.state import set_curdoc

    from app.page import LocalFast

    def urls(prepare) -> list[str]:
        doc = Document()
        with set_curdoc(doc):
            prepare(doc)
            part = pn.Column(pn.pane.HTML("<b>x</b>"), pn.widgets.FloatSlider(), design=LocalFast)
            doc.add_root(part.get_root(doc))
            part.loading = True  # what the who-wins map did when it started to compute
        return [str(m.url) for m in doc.models if isinstance(m, ImportedStyleSheet)]

    plain = urls(lambda doc: None)
    assert any(url.startswith(CDN_DIST) for url in plain)  # Panel's own fallback (if it stops, this can go)
    served = urls(session.serve_panel_files)
    assert served and [url for url in served if url.startswith(("http:", "https:", "//"))] == []


def _held_changes(doc: Document, change) -> list:
    """The events ``change()`` makes while ``doc`` is on hold (Panel holds a document while a thread updates it)."""
    doc.hold("collect")
    try:
        change()
        return list(doc.callbacks._held_events)
    finally:
        doc.callbacks._held_events = []
        doc.callbacks._hold = None


def test_a_model_not_yet_sent_is_sent_in_full_after_a_browser_change():
    """The page once stayed empty: a browser change (its URL) arrived while the server's change adding the page's
    content was held; bokeh then counted the new models as sent, so the change named them by id only and the
    browser rejected it ("reference p… isn't known"). Models the browser's own change creates still count as sent."""
    from bokeh.models import Column, Div

    hardening.install()
    doc = Document()
    column = Column()
    doc.add_root(column)
    doc.to_json()  # the browser pulls the page
    built = Div(text="built on the server")

    def server_change_then_browser_change():
        column.children = [built]  # held: not serialized yet
        doc.apply_json_patch(
            {
                "events": [
                    {"kind": "ModelChanged", "model": {"id": column.id}, "attr": "width", "new": 10},
                    {"kind": "ModelChanged", "model": {"id": column.id}, "attr": "css_classes", "new": ["x"]},
                ]
            }
        )

    events = _held_changes(doc, server_change_then_browser_change)
    patch = Protocol().create("PATCH-DOC", [e for e in events if getattr(e, "attr", None) == "children"])
    [change] = patch.content["events"]
    assert change["new"][0]["id"] == built.id and "attributes" in change["new"][0]  # in full, not {"id": …}

    from_browser = {"type": "object", "name": "Div", "id": "c1", "attributes": {"text": "made in the browser"}}
    doc.apply_json_patch(
        {"events": [{"kind": "ModelChanged", "model": {"id": column.id}, "attr": "children", "new": [from_browser]}]}
    )
    assert doc.get_model_by_id("c1") in doc.models.synced_references


class _Payload(param.Parameterized):
    run = param.Parameter(default=None)
    traces = param.Parameter(default=None)
    seed = param.Integer(1)


def test_drop_payloads_resets_parameters_without_firing_watchers():
    obj = _Payload(run=list(range(10)), traces="big", seed=5)
    fired = []
    obj.param.watch(fired.append, ["run", "traces"])
    session.drop_payloads(obj)
    assert obj.run is None and obj.traces is None and obj.seed == 5 and fired == []


def test_release_hooks_run_once_when_the_session_is_destroyed(monkeypatch):
    class Ctx:
        id = "session-1"

    doc = Document()  # bokeh checks the callback's signature on registration
    doc._session_context = lambda: Ctx()
    monkeypatch.setattr(type(pn.state), "curdoc", property(lambda self: doc))
    calls = []
    session.release_on_destroy(lambda: calls.append("callable"))
    session.release_on_destroy(type("R", (), {"release": lambda self: calls.append("release")})())
    session.release_on_destroy(lambda: 1 / 0)  # a failing hook does not stop the others
    obj = _Payload(run=[1, 2, 3])
    session.release_on_destroy(obj)
    callbacks = list(doc.session_destroyed_callbacks)
    assert len(callbacks) == 1 and "session-1" in session._releases
    callbacks[0](None)  # Panel discards a warm-up document with None for the session context
    callbacks[0](Ctx())
    assert calls == ["callable", "release"] and obj.run is None
    assert "session-1" not in session._releases


def test_memory_is_trimmed_only_after_sessions_end():
    class Server:
        def __init__(self):
            self.sessions = []

        def get_sessions(self):
            return self.sessions

    server, calls = Server(), []
    trimmer = serve.MemoryTrimmer(server)
    trimmer._trim = calls.append
    for count in (0, 3, 5, 5, 2, 2, 0, 4):
        server.sessions = [object()] * count
        trimmer()
    assert calls == [0, 0]  # after 5 → 2 and 2 → 0, never while sessions are added


# ------------------------------------------------------------------------------------------- real servers
@pytest.mark.parametrize("procs", ["1", "2"])
def test_broken_app_fails_the_check_and_exits_instead_of_serving(tmp_path, procs):
    broken = tmp_path / "broken.py"
    broken.write_text("import panel as pn\nraise RuntimeError('broken on purpose')\n")
    with pytest.raises(serve.AppStartupError, match="broken on purpose"):
        serve.check_app(str(broken))
    port = session_client.free_port()
    log = tmp_path / "broken.log"
    proc = session_client.start_server(port, log, ["--stats-interval", "0", "--num-procs", procs], script=str(broken))
    try:
        code = proc.wait(120)  # with two processes, each fails its warm-up and the parent stops with them
    finally:
        session_client.stop_server(proc)
    assert code == 1
    assert "failed during warm-up" in log.read_text()


def test_check_mode_passes_for_a_working_app(tmp_path):
    code = (
        "import sys, app.serving.serve as s\n"
        f"s.app_script = lambda: {fixture_app(tmp_path)!r}\n"
        "sys.exit(s.main(['--check']))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "PYTHONPATH": str(REPO)},
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "warm-up passed" in done.stdout


def test_port_in_use_is_exit_code_1(tmp_path):
    with served(tmp_path, "--stats-interval", "0", script=fixture_app(tmp_path)) as (url, _, _):
        port = int(url.rsplit(":", 1)[1])
        log = tmp_path / "second.log"
        second = session_client.start_server(port, log, ["--stats-interval", "0"], script=fixture_app(tmp_path))
        try:
            assert second.wait(120) == 1
        finally:
            session_client.stop_server(second)


def test_callback_error_is_logged_server_side_and_the_user_gets_a_short_message(tmp_path):
    with served(tmp_path, "--stats-interval", "0", script=fixture_app(tmp_path)) as (url, proc, log):

        async def click() -> list[str]:
            async with await session_client.BokehClient.connect(url) as client:
                button = next(m for m in client.doc.models if isinstance(m, Button))
                await client.send_event(ButtonClick(button))
                await client.wait_until(lambda: bool(session_client.notifications(client.doc)), 30)
                return session_client.notifications(client.doc)

        messages = run(click(), 120)
        text = wait_for_log(log, "SECRET-DETAIL")
        server_exit_code_while_running = proc.poll()
    assert server_exit_code_while_running is None  # the server survived the error
    assert len(messages) == 1
    incident = re.search(r"incident ([0-9a-f]{8})", messages[0]).group(1)
    assert "SECRET-DETAIL" not in messages[0] and "Traceback" not in messages[0] and ".py" not in messages[0]
    assert f"incident {incident}" in text and "Traceback (most recent call last)" in text


def test_a_crash_in_native_code_writes_every_thread_s_stack_to_the_log(tmp_path):
    """A segmentation fault (a kernel or a library writing out of bounds) ends the process; the log says where each
    thread was, instead of nothing."""
    with served(tmp_path, "--stats-interval", "0", script=fixture_app(tmp_path)) as (_, proc, log):
        resource.prlimit(proc.pid, resource.RLIMIT_CORE, (0, 0))  # no core file of the server in the checkout
        os.kill(proc.pid, signal.SIGSEGV)
        code = proc.wait(60)
        text = log.read_text()
    assert code == -signal.SIGSEGV
    assert "Fatal Python error: Segmentation fault" in text, text[-3000:]
    assert "Current thread" in text and 'File "' in text, text[-3000:]  # the Python stacks


def test_a_page_closed_mid_write_is_not_logged_as_an_error(caplog):
    """tornado's write task ends in WebSocketClosedError when a tab closes mid-write: one debug line, no traceback;
    any other unhandled error on the loop is still logged by asyncio."""
    import asyncio
    import gc

    from tornado.websocket import WebSocketClosedError

    from app.serving.hardening import log, quiet_closed_websockets

    async def closed():
        raise WebSocketClosedError()

    async def broken():
        raise RuntimeError("a real failure")

    loop = asyncio.new_event_loop()
    try:
        quiet_closed_websockets(loop)
        with caplog.at_level("DEBUG", logger=log.name):
            tasks = [loop.create_task(closed()), loop.create_task(broken())]
            loop.run_until_complete(asyncio.wait(tasks))
            del tasks
            gc.collect()  # "never retrieved" is reported when a failed task is collected
    finally:
        loop.close()
    errors = [r for r in caplog.records if r.levelname == "ERROR"]
    assert len(errors) == 1 and "a real failure" in str(errors[0].exc_info[1])
    assert any("a page closed during a write" in r.getMessage() for r in caplog.records)
