#!/usr/bin/env python3
"""Start, probe and stop an isl dashboard server for the load script, the benchmarks and the serving tests: its
processes (its workers and their long jobs' processes), their memory, and its log (sessions, releases and memory
trims, per process). :mod:`session_client` re-exports the server's side, :mod:`load_test` the log's."""

from __future__ import annotations

import asyncio
import contextlib
import os
import re
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterable
from pathlib import Path
from urllib.parse import urlparse

REPO = Path(__file__).resolve().parents[1]
#: the environment ./scripts/serve and the image give the server (the allocator: app/serving/memory.py)
SERVE_ENV = {"PYTHONMALLOC": "malloc"}
LOOPBACK = {"127.0.0.1", "localhost", "::1"}


def check_loopback(url: str) -> None:
    host = urlparse(url).hostname or ""
    if host not in LOOPBACK:
        raise SystemExit(f"load tests run against loopback only, got {url}")


def descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (Linux ``/proc``): a server's workers, their long jobs' processes."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        with contextlib.suppress(OSError, IndexError, ValueError):
            children.setdefault(int(stat.read_text().rsplit(")", 1)[1].split()[1]), []).append(int(stat.parent.name))
    found, todo = [], [pid]
    while todo:
        found += (new := children.get(todo.pop(), []))
        todo += new
    return found


def rss_mb(pid: int) -> float:
    """Resident memory of process ``pid`` and its descendants in MB (Linux ``/proc``; ``--num-procs`` forks)."""
    total = 0.0
    for p in [pid, *descendants(pid)]:
        with contextlib.suppress(OSError, StopIteration), open(f"/proc/{p}/status") as f:
            total += next(int(line.split()[1]) for line in f if line.startswith("VmRSS:")) / 1024
    return total


def cmdline(pid: int) -> bytes:
    """The command line of process ``pid`` as ``/proc`` holds it (NUL-separated), or ``b""`` once it is gone."""
    with contextlib.suppress(OSError):
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    return b""


def server_processes(pid: int) -> list[int]:
    """The processes of server ``pid`` that serve sessions: its forked workers (children running the same command),
    or ``pid`` itself when it serves alone (its only children are then its long jobs' processes)."""
    own = cmdline(pid)
    workers = [p for p in descendants(pid) if cmdline(p) == own and own]
    return [p for p in workers if Path(f"/proc/{p}/stat").exists() and _parent(p) == pid] or [pid]


def _parent(pid: int) -> int:
    with contextlib.suppress(OSError, IndexError, ValueError):
        return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
    return 0


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


def start_server(
    port: int,
    log_path: Path,
    extra: Iterable[str] = (),
    env: dict | None = None,
    script: str | None = None,
    repo: Path = REPO,
) -> subprocess.Popen:
    """Start ``python -m app.serving`` of checkout ``repo`` (default: this one) on 127.0.0.1:``port`` (optionally
    serving another app ``script``)."""
    # a checkout from before app/serving has app/serve.py (chosen by the tree: the editable install of this one
    # would supply a missing app.serving from here)
    module = "app.serving.serve" if (repo / "app" / "serving").is_dir() else "app.serve"
    code = (
        f"import sys\nimport {module} as s\n"
        + (f"s.app_script = lambda: {script!r}\n" if script else "")
        + "sys.exit(s.main(sys.argv[1:]))"
    )
    # this checkout served as scripts/serve serves it; an older checkout as it was (its scripts/serve set nothing)
    served_as = SERVE_ENV if repo.resolve() == REPO else {}
    full_env = {
        **os.environ,
        **served_as,
        "PYTHONPATH": f"{repo}{os.pathsep}{os.environ.get('PYTHONPATH', '')}",
        **(env or {}),
    }
    extra = list(extra)
    if "--num-procs" not in extra:  # one process unless asked: a test's server is small and starts fast
        extra += ["--num-procs", "1"]
    with open(log_path, "w") as log:  # the child keeps its own descriptor
        return subprocess.Popen(
            [sys.executable, "-c", code, "--address", "127.0.0.1", "--port", str(port), *extra],
            stdout=log,
            stderr=subprocess.STDOUT,
            env=full_env,
            cwd=repo,
        )


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


# ------------------------------------------------------------------------------------------------ its log
STATS = re.compile(r"isl stats: sessions=(\d+) connections=(\d+) pending_releases=(\d+) rss_mb=([\d.]+)")


TRIMS = re.compile(r"isl trim: sessions=(\d+) pending_releases=(\d+) collected=\w+ rss_mb=([\d.]+)")


def server_stats(log_path: Path) -> list[tuple[int, int, int, float]]:
    """Every ``isl stats`` line the server has logged so far (``--stats-interval``)."""
    return [(int(a), int(b), int(c), float(d)) for a, b, c, d in STATS.findall(log_path.read_text())]


def server_trims(log_path: Path) -> list[tuple[int, int]]:
    """``(sessions, pending releases)`` of every ``isl trim`` line so far (app.serving.memory.MemoryTrimmer)."""
    return [(int(a), int(b)) for a, b, _ in TRIMS.findall(log_path.read_text())]


LINES = re.compile(r"isl (stats|trim): sessions=(\d+) (?:connections=\d+ )?pending_releases=(\d+) .*pid=(\d+)")


def released_by_process(log_path: Path) -> dict[int, bool]:
    """Per server process (the ``pid=`` of its ``isl stats`` and ``isl trim`` lines): whether it has trimmed its memory
    with no session left and every release hook run since it last held a session."""
    released: dict[int, bool] = {}
    for kind, sessions, pending, pid in LINES.findall(log_path.read_text()):
        if sessions != "0" or pending != "0":
            released[int(pid)] = False
        elif kind == "trim" or int(pid) not in released:
            released[int(pid)] = True
    return released


async def all_released(log_path: Path, trims_before: int, timeout: float = 120.0) -> bool:
    """Wait until the server has trimmed its memory with no session left and every release hook run (an ``isl
    trim`` line after the first ``trims_before``), in every one of its processes; False after ``timeout`` seconds."""
    deadline = time.perf_counter() + timeout
    while time.perf_counter() < deadline:
        if (0, 0) in server_trims(log_path)[trims_before:] and all(released_by_process(log_path).values()):
            return True
        await asyncio.sleep(0.2)
    return False
