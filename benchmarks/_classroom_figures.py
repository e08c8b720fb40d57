"""What the classroom benchmark (``bench_classroom.py``) measures in one server's run, and its table: one row per
figure, one column per server, in all and per server process."""

from __future__ import annotations

import statistics
import sys
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import session_client as sc  # the scripted client reads a server's processes and their RSS


@dataclass
class Figures:
    errors: list[str] = field(default_factory=list)
    liveness: list[float] = field(default_factory=list)
    baseline: list[float] = field(default_factory=list)
    loaded: list[float] = field(default_factory=list)
    ready_idle: list[float] = field(default_factory=list)
    ready_loaded: list[float] = field(default_factory=list)
    rss: list[float] = field(default_factory=list)
    rss_idle: float = float("nan")
    rss_closed: float = float("nan")
    heavy_runs: int = 0
    worst_tables: int = 0
    processes: dict[int, list[float]] = field(default_factory=dict)  # a worker's pid → its RSS samples, in order
    pages: dict[int, int] = field(default_factory=dict)  # a worker's pid → the pages it built

    def sample(self, pid: int) -> float:
        """The server's RSS in all (returned), and each of its processes' (kept)."""
        for worker in sc.server_processes(pid):
            self.processes.setdefault(worker, []).append(sc.rss_mb(worker))
        return sc.rss_mb(pid)


def pct(data: list[float], q: float) -> float:
    if not data:
        return float("nan")
    data = sorted(data)
    return data[min(len(data) - 1, int(q * len(data)))]


def rows(f: Figures) -> list[tuple[str, str]]:
    ms = lambda x: f"{1000 * x:.0f} ms"  # noqa: E731
    med = lambda xs: statistics.median(xs) if xs else float("nan")  # noqa: E731
    return [
        ("errors", f"{len(f.errors)}" + (f" (first: {f.errors[0][:60]})" if f.errors else "")),
        (
            "/liveness p50 / p99 / max",
            f"{ms(pct(f.liveness, 0.5))} / {ms(pct(f.liveness, 0.99))} / "
            f"{ms(pct(f.liveness, 1.0))} ({len(f.liveness)})",
        ),
        (
            "students' slider → data p50 / p95, baseline",
            f"{ms(pct(f.baseline, 0.5))} / {ms(pct(f.baseline, 0.95))} ({len(f.baseline)})",
        ),
        (
            "students' slider → data p50 / p95, loaded",
            f"{ms(pct(f.loaded, 0.5))} / {ms(pct(f.loaded, 0.95))} ({len(f.loaded)})",
        ),
        (
            "new default page ready, idle / loaded (median, max)",
            f"{med(f.ready_idle):.2f} s / {med(f.ready_loaded):.2f} s, "
            f"{max(f.ready_loaded, default=float('nan')):.2f} s",
        ),
        (
            "server RSS idle / peak / after close",
            f"{f.rss_idle:.0f} / {max(f.rss, default=float('nan')):.0f} / {f.rss_closed:.0f} MB",
        ),
        ("heavy runs shown / worst-case answers", f"{f.heavy_runs} / {f.worst_tables}"),
    ] + [
        (
            f"process {k}: RSS idle / peak / after close, pages built",
            f"{rss[0]:.0f} / {max(rss):.0f} / {rss[-1]:.0f} MB, {f.pages.get(pid, '–')}",
        )
        for k, (pid, rss) in enumerate(f.processes.items(), 1)
    ]


def report(columns: dict[str, Figures]) -> str:
    """One row per figure, one column per server (``before`` / ``after`` or just this checkout)."""
    table = [dict(rows(f)) for f in columns.values()]
    names = list(dict.fromkeys(name for t in table for name in t))  # a column with more processes has more rows
    width = max(len(name) for name in names)
    cells = [max(len(h), *(len(v) for v in t.values())) for h, t in zip(columns, table, strict=True)]
    lines = [f"{'':<{width}}  " + "  ".join(f"{h:<{c}}" for h, c in zip(columns, cells, strict=True))]
    for name in names:
        lines.append(
            f"{name:<{width}}  " + "  ".join(f"{t.get(name, '–'):<{c}}" for t, c in zip(table, cells, strict=True))
        )
    return "\n".join(lines)
