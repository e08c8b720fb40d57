#!/usr/bin/env python3
"""Classroom load test for the isl dashboard: many concurrent sessions moving a slider.

Each simulated student is one bokeh session opened over the websocket exactly as a browser opens it (same
``Origin`` header, same session token, same ``PULL-DOC`` / ``PATCH-DOC`` messages, a ``document_ready`` event
after the pull), but without rendering: the client keeps its own copy of the document, so it sees every update
the server sends. Every ``--interval`` seconds (±25 % jitter) each session sets a slider to a new value (``value``
and ``value_throttled`` in two messages, as a browser sends a released drag) and measures the *update latency*: the
time until the server's first change to plot data (a ``ColumnDataSource``) arrives. An ``ERROR`` reply, a lost
connection, or no update within ``--update-timeout`` counts as an error.

Usage (the long classroom run: 100 sessions for 5 minutes, against a server this script starts):

    PYTHONPATH=. python scripts/load_test.py --sessions 100 --duration 300

the memory run (open and close 50 sessions three times; the server's RSS after each round):

    PYTHONPATH=. python scripts/load_test.py --memory 3 --sessions 50

or against a running server (``./scripts/serve`` or the container)::

    python scripts/load_test.py --url http://127.0.0.1:5006 --server-pid <pid> --sessions 100 --duration 300

It prints one line per figure: sessions held, errors, update latency (median, p95, max), the server's resident
memory before / with every session open, and RSS per session. Only loopback URLs are accepted. The test suite
(``tests/serving/test_load.py``) runs a short version of the same function, :func:`run_load`; the classroom benchmark
(:ref:`performance-classroom`) is built on this script's client.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import sys
import time
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from server_control import (  # noqa: F401  (the server's log, read here and by the classroom benchmark)
    all_released,
    released_by_process,
    server_stats,
    server_trims,
)
from session_client import (  # (the client lives beside this script)
    CONNECT_TIMEOUT_S,
    BokehClient,
    check_loopback,
    find_slider,
    free_port,
    new_value,
    rss_mb,
    start_server,
    stop_server,
    wait_healthy,
)


# -------------------------------------------------------------------------------------------------------- load
@dataclass
class LoadResult:
    sessions: int  # sessions that connected
    held: int  # sessions still connected with zero errors at the end
    updates: int
    errors: list[str]
    latencies: list[float]  # seconds, one per slider change that got its update
    rss_before_mb: float
    rss_loaded_mb: float  # all sessions open, before the slider changes
    rss_peak_mb: float = float("nan")  # sampled every 5 s while the sliders move
    rss_end_mb: float = float("nan")  # when the last change was answered

    def p(self, q: float) -> float:
        if not self.latencies:
            return float("nan")
        data = sorted(self.latencies)
        return data[min(len(data) - 1, int(q * len(data)))]

    @property
    def rss_per_session_mb(self) -> float:
        return (self.rss_loaded_mb - self.rss_before_mb) / max(self.sessions, 1)

    def report(self) -> str:
        return "\n".join(
            [
                f"sessions connected        {self.sessions}",
                f"sessions held, 0 errors   {self.held}",
                f"slider updates            {self.updates}",
                f"errors                    {len(self.errors)}"
                + (f"  (first: {self.errors[0]})" if self.errors else ""),
                f"update latency median     {1000 * self.p(0.5):.0f} ms",
                f"update latency p95        {1000 * self.p(0.95):.0f} ms",
                f"update latency max        {1000 * self.p(1.0):.0f} ms",
                f"server RSS before         {self.rss_before_mb:.0f} MB",
                f"server RSS, all open      {self.rss_loaded_mb:.0f} MB",
                f"RSS per session           {self.rss_per_session_mb:.1f} MB",
                f"server RSS, peak / end    {self.rss_peak_mb:.0f} MB / {self.rss_end_mb:.0f} MB (sliders moving)",
            ]
        )


async def _student(
    base_url: str,
    index: int,
    slider_pattern: str,
    duration: float,
    interval: float,
    update_timeout: float,
    opened: asyncio.Event,
    all_open: asyncio.Event,
    out: dict[int, tuple[BokehClient | None, list[float], list[str]]],
) -> None:
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
            _, t0 = await client.change(slider, value=value)
            await client.change(slider, value_throttled=value)  # a second message, as from a browser
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


async def run_load(
    base_url: str,
    *,
    sessions: int,
    duration: float,
    interval: float = 3.0,
    slider: str = "",
    server_pid: int | None = None,
    update_timeout: float = 30.0,
    connect_batch: int = 10,
) -> LoadResult:
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
            tasks.append(
                asyncio.ensure_future(
                    _student(base_url, i, slider, duration, interval, update_timeout, opened, all_open, out)
                )
            )
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
    return LoadResult(
        len(clients), held, len(latencies), errors, latencies, rss_before, rss_loaded, max([*peak, rss_end]), rss_end
    )


# ------------------------------------------------------------------------------------------------------ memory
@dataclass
class MemoryRound:
    rss_before_mb: float
    live_open: int  # sessions the server reported with all of the round's sessions open
    rss_open_mb: float  # all sessions of the round open and idle
    rss_after_mb: float  # all closed, destroyed by the server, garbage collected
    live_after: int  # sessions the server still holds after the round
    pending_after: int  # of which release hooks have not run


async def _wait_idle(client: BokehClient, quiet_s: float = 1.0, limit: float = 60.0) -> None:
    deadline = time.perf_counter() + limit
    while time.perf_counter() < deadline:
        count = len(client.patches)
        await asyncio.sleep(quiet_s)
        if len(client.patches) == count:
            return


async def memory_round(
    base_url: str, server_pid: int, log_path: Path, sessions: int, *, batch: int = 5, release_timeout: float = 120.0
) -> MemoryRound:
    """Open ``sessions`` sessions, let them settle, close them, wait until the server has destroyed them."""
    check_loopback(base_url)
    rss_before = rss_mb(server_pid)
    clients: list[BokehClient] = []
    for first in range(0, sessions, batch):
        clients += await asyncio.gather(*(BokehClient.connect(base_url) for _ in range(min(batch, sessions - first))))
    await asyncio.gather(*(_wait_idle(c) for c in clients))
    rss_open = rss_mb(server_pid)
    live_open = await _next_stats(log_path)
    trims = len(server_trims(log_path))
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
    await all_released(log_path, trims, max(deadline - time.perf_counter(), 0.0))  # and handed the memory back
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
    lines = [
        f"round {i + 1}: RSS {r.rss_before_mb:.0f} MB → {r.rss_open_mb:.0f} MB with {r.live_open} open → "
        f"{r.rss_after_mb:.0f} MB after closing ({r.live_after} sessions left, {r.pending_after} unreleased); "
        f"per idle session {(r.rss_open_mb - r.rss_before_mb) / sessions:.1f} MB"
        for i, r in enumerate(rounds)
    ]
    drift = max(r.rss_after_mb for r in rounds[1:]) / first - 1 if len(rounds) > 1 else 0.0
    lines.append(f"RSS drift after round 1: {100 * drift:+.1f} % (limit +10 %)")
    return "\n".join(lines)


MEMORY_SERVER_ARGS = [
    "--unused-session-lifetime",
    "1000",
    "--check-unused-sessions",
    "500",
    "--stats-interval",
    "500",
    "--trim-interval",
    "500",
]


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
    p.add_argument(
        "--memory",
        type=int,
        metavar="ROUNDS",
        help="instead: open and close --sessions sessions ROUNDS times and report the server's RSS "
        "(starts its own server)",
    )
    opts = p.parse_args(argv)
    if opts.memory:
        return memory_main(opts.sessions, opts.memory)
    proc = None
    url, pid = opts.url, opts.server_pid
    if url is None:
        port = free_port()
        log_path = Path(os.environ.get("TMPDIR", "/tmp")) / f"isl-load-{port}.log"
        proc = start_server(
            port, log_path, ["--num-threads", str(opts.num_threads), "--num-procs", str(opts.num_procs)]
        )
        startup = wait_healthy(port, 180, proc)
        print(f"server started in {startup:.1f} s (log: {log_path})", flush=True)
        url, pid = f"http://127.0.0.1:{port}", proc.pid
    try:
        result = asyncio.run(
            run_load(
                url,
                sessions=opts.sessions,
                duration=opts.duration,
                interval=opts.interval,
                slider=opts.slider,
                server_pid=pid,
            )
        )
    finally:
        if proc is not None:
            stop_server(proc)
    print(result.report())
    if opts.json:
        print(
            json.dumps(
                {
                    "sessions": result.sessions,
                    "held": result.held,
                    "updates": result.updates,
                    "errors": len(result.errors),
                    "p50_ms": 1000 * result.p(0.5),
                    "p95_ms": 1000 * result.p(0.95),
                    "rss_per_session_mb": result.rss_per_session_mb,
                }
            )
        )
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
    ok = all(r.live_after == 0 and r.pending_after == 0 for r in results) and all(
        r.rss_after_mb <= 1.10 * first for r in results[1:]
    )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
