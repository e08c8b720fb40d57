"""The classroom scenario: 40 students moving sliders while 4 sessions try to stall the server.

    PYTHONPATH=. python benchmarks/bench_classroom.py [--students 40] [--duration 300] [--baseline 60]
    PYTHONPATH=. python benchmarks/bench_classroom.py --before ../isl-before   # a worktree of the previous commit
    PYTHONPATH=. python benchmarks/bench_classroom.py --before . --before-env PYTHONMALLOC=pymalloc  # a setting
    PYTHONPATH=. python benchmarks/bench_classroom.py --url http://127.0.0.1:5006 --server-pid PID --log LOG
    PYTHONPATH=. python benchmarks/bench_classroom.py --procs 1,0   # one process, then one per core (the default)

Starts ``python -m app.serving`` on a free loopback port (or measures a running one) and, with the scripted
browser-like client of ``scripts/session_client.py``:

1. *idle*: the server's RSS, and how long a default page takes to be ready (connect → first run's plot data);
2. *baseline*: ``--students`` sessions each move the σ slider every ~3 s for ``--baseline`` s (slider → plot-data
   latency), while ``/liveness`` is probed every 0.25 s from a separate process;
3. *loaded*: the same students go on for ``--duration`` s while four hostile-heavy sessions run beside them — two
   open ``HEAVY`` (m = 6, ν = 10⁴, horizon 1000, every extra filter: ≈ 10⁶ steps a run) and press "new noise"
   again as soon as a run is shown, two open the worst-case tab at its maximum (m = 6, 11 σ, horizon 2000) and
   press Compute again as soon as a table (or a refusal) is shown; a fresh default page is opened every 30 s;
   RSS is sampled every 2 s;
4. *closed*: every session is closed; once the server reports none left, its RSS.

Every session opens as a browser does (the page's HTML, then its websocket). Prints one table: errors, liveness
p50/p99/max, the students' latency p50/p95 (baseline and loaded), page-ready times (idle and loaded), RSS (idle,
peak, after close), what the heavy sessions got done — in all, then per server process (its RSS with its long
jobs' processes, the pages it built). The load average is printed: figures compare only on an idle machine.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import random
import re
import sys
import time
from pathlib import Path

from bokeh.events import ButtonClick
from bokeh.models import Markup

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import load_test as lt  # the load scenario and the scripted client live in scripts/
import session_client as sc
from _classroom_figures import Figures, report
from _liveness import LivenessProbe

HEAVY = (
    "alpha=1&w=1&sigma=1&m=6&nu=10000&horizon=1000"
    '&extra_filters=["kbf_mismatched","kbf_minimax","kbf_adaptive","isl_model"]'
)
WORST = "m=6&wc_n_sigma=11&wc_horizon=2000"
TIMELINE: list = []
BUILT = re.compile(r"isl page: built for session \S+ in process (\d+)")  # app.serving.offloop's line
DONE = re.compile(r"Simulated in|Failed|Refused|refused|queue|Cancelled")


def _traj(doc):
    return doc.get_model_by_name("traj-1-isl")


async def page_ready(base: str, figures: Figures, query: str = "") -> float | None:
    """Seconds from opening a page to its first run's plot data (a full client: it applies every patch)."""
    t0 = time.perf_counter()
    try:
        client = await sc.open_page(base, query)
    except Exception as exc:  # noqa: BLE001
        figures.errors.append(f"page: {exc!r}")
        return None
    try:
        if not await client.wait_until(
            lambda: _traj(client.doc) is not None and len(_traj(client.doc).data["y"]), 120.0
        ):
            figures.errors.append("page: no run within 120 s")
            return None
        return time.perf_counter() - t0
    finally:
        figures.errors.extend(client.errors)
        await client.close()


def _button(doc, label: str):
    return next((m for m in doc.models if getattr(m, "label", None) == label and type(m).__name__ == "Button"), None)


async def woken_at(stop: asyncio.Event, client) -> None:
    """Wake ``client``'s waits when ``stop`` is set: they end at the stop, not at the next message of a run that, on a
    loaded machine, may come minutes later."""
    await stop.wait()
    client.wake()


async def heavy_runs(base: str, stop: asyncio.Event, figures: Figures) -> None:
    """Open HEAVY and press "new noise" each time its run is shown."""
    client = await sc.open_page(base, HEAVY)
    waker = asyncio.ensure_future(woken_at(stop, client))
    try:
        await client.widgets()
        await client.wait_until(
            lambda: stop.is_set() or (_traj(client.doc) is not None and len(_traj(client.doc).data["y"])), 300.0
        )
        while not stop.is_set() and not client.closed:
            before = list(_traj(client.doc).data["y"][:8])
            await client.send_event(ButtonClick(_button(client.doc, "new noise")))
            changed = await client.wait_until(
                lambda b=before: list(_traj(client.doc).data["y"][:8]) != b or stop.is_set(), 300.0
            )
            if changed and not stop.is_set():
                figures.heavy_runs += 1
                TIMELINE.append((time.perf_counter(), "heavy run shown", 0.0))
            elif not changed:
                figures.errors.append("heavy: no new run within 300 s")
    finally:
        waker.cancel()
        figures.errors.extend(client.errors)
        await client.close()


async def worst_cases(base: str, stop: asyncio.Event, figures: Figures) -> None:
    """Open the worst-case tab at its maximum and press Compute each time a table or a refusal is shown."""
    client = await sc.open_page(base, WORST)
    waker = asyncio.ensure_future(woken_at(stop, client))
    try:
        tabs = next(m for m in client.doc.models if type(m).__name__ == "Tabs")
        await client.change(tabs, active=2)
        await client.wait_until(lambda: _button(client.doc, "Compute") is not None, 120.0)
        while not stop.is_set() and not client.closed:
            notes = {m.id: m.text for m in client.doc.models if isinstance(m, Markup)}
            await client.send_event(ButtonClick(_button(client.doc, "Compute")))
            TIMELINE.append((time.perf_counter(), "worst case pressed", 0.0))

            def answered(notes=notes) -> bool:
                return stop.is_set() or any(
                    isinstance(m, Markup) and m.text != notes.get(m.id) and DONE.search(m.text or "")
                    for m in client.doc.models
                )

            if await client.wait_until(answered, 900.0) and not stop.is_set():
                figures.worst_tables += 1
                await client.wait_until(lambda: stop.is_set(), 2.0)  # a student reads the table, then asks again
    finally:
        waker.cancel()
        figures.errors.extend(client.errors)
        await client.close()


async def students(
    base: str, n: int, figures: Figures, phases: list[tuple[float, list[float]]], stop: asyncio.Event
) -> None:
    """``n`` light sessions; in each phase (seconds, list to fill) each moves the σ slider every ~3 s."""
    clients = []
    for first in range(0, n, 10):
        batch = await asyncio.gather(
            *(sc.open_page(base, light=True) for _ in range(first, min(first + 10, n))),
            return_exceptions=True,
        )
        for c in batch:
            (figures.errors.append(f"student connect: {c!r}") if isinstance(c, BaseException) else clients.append(c))
        for c in clients[first:]:
            if not await c.widgets():
                figures.errors.append("student: no controls within 120 s")

    # one sequence per student across the phases, and the last value each sent: a generator restarted at each phase
    # repeats the baseline's values, and the client's copy of the slider does not follow the client's own changes (the
    # server does not echo them back), so a phase's first change could be the value the server already held — not a
    # change, and nothing to answer
    rngs = [random.Random(k) for k in range(len(clients))]
    sent: list[float | None] = [None] * len(clients)

    async def one(k: int, client, until: float, out: list[float]) -> None:
        rng = rngs[k]
        await asyncio.sleep(rng.uniform(0, 3.0))
        while time.perf_counter() < until and not client.closed:
            slider = sc.find_slider(client.doc, "σ")
            previous, shown = sent[k], slider.value  # the last value sent, the one the server last sent this client
            value = sent[k] = sc.new_value(slider, rng, sent[k])
            msgid, t0 = await client.change(slider, value=value, value_throttled=value)
            if await client.wait_until(lambda t0=t0: client.data_update_after(t0) is not None, 30.0):
                out.append(client.data_update_after(t0) - t0)
                TIMELINE.append((t0, "student", out[-1]))
            else:  # for diagnosis: what was sent and what came back; then whether the update only came late
                seen = client.seen_since(t0, msgid)
                late = await client.wait_until(lambda t0=t0: client.data_update_after(t0) is not None, 90.0)
                came = client.data_update_after(t0)
                figures.errors.append(
                    f"student: no plot update within 30 s (σ slider sent {value:.3f}, last sent {previous}, last set by"
                    f" the server {shown:.3f}; {seen}; "
                    + (f"the update came {came - t0:.1f} s after the change)" if late and came else "none in 120 s)")
                )
            await asyncio.sleep(3.0 * rng.uniform(0.75, 1.25))

    try:
        for seconds, out in phases:
            until = time.perf_counter() + seconds
            results = await asyncio.gather(
                *(one(k, c, until, out) for k, c in enumerate(clients)), return_exceptions=True
            )
            figures.errors.extend(f"student: {r!r}" for r in results if isinstance(r, BaseException))
            if out is phases[0][1]:
                stop.set()  # the baseline is over: the heavy sessions may start
    finally:
        stop.set()
        for c in clients:
            figures.errors.extend(c.errors)
        await asyncio.gather(*(c.close() for c in clients))


async def all_processes_up(pid: int, timeout: float = 60.0) -> bool:
    """Whether each serving process of server ``pid`` has its long jobs' fork server, done with the warm-up's job (the
    fork server alive, no child of it left): the server starts them after its port opens, and an idle figure taken
    before would leave them out of idle but not out of after close."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        servers = [
            [c for c in sc.descendants(w) if b"multiprocessing.forkserver" in sc.cmdline(c)]
            for w in sc.server_processes(pid)
        ]
        if all(len(f) == 1 and not sc.descendants(f[0]) for f in servers):
            return True
        await asyncio.sleep(0.1)
    return False


async def scenario(base: str, pid: int, log: Path | None, n: int, baseline: float, duration: float) -> Figures:
    fig = Figures()
    if not await all_processes_up(pid):
        fig.errors.append("idle: a serving process has no long jobs' fork server after 60 s (idle RSS without it)")
    fig.rss_idle = fig.sample(pid)
    for _ in range(3):
        if (t := await page_ready(base, fig)) is not None:
            fig.ready_idle.append(t)
    baseline_over, stop_heavy = asyncio.Event(), asyncio.Event()
    probe = LivenessProbe(base)
    crowd = asyncio.ensure_future(
        students(base, n, fig, [(baseline, fig.baseline), (duration, fig.loaded)], baseline_over)
    )
    await baseline_over.wait()
    heavy = [asyncio.ensure_future(heavy_runs(base, stop_heavy, fig)) for _ in range(2)]
    heavy += [asyncio.ensure_future(worst_cases(base, stop_heavy, fig)) for _ in range(2)]
    t_end = time.perf_counter() + duration
    next_page = time.perf_counter() + 30.0
    while time.perf_counter() < t_end:
        fig.rss.append(fig.sample(pid))
        if time.perf_counter() >= next_page:
            next_page += 30.0
            if (t := await page_ready(base, fig)) is not None:
                fig.ready_loaded.append(t)
        await asyncio.sleep(2.0)
    stop_heavy.set()
    trims = len(lt.server_trims(log)) if log is not None else 0
    await crowd
    for task in heavy:
        try:
            await asyncio.wait_for(task, 60.0)
        except Exception as exc:  # noqa: BLE001
            fig.errors.append(f"heavy session: {exc!r}")
    await probe.finish(fig, TIMELINE)
    fig.rss.append(fig.sample(pid))
    deadline = time.perf_counter() + 120.0  # unused sessions are released 10 s after their last connection
    while time.perf_counter() < deadline:
        stats = lt.server_stats(log) if log is not None else []
        if stats and stats[-1][0] == 0 and all(lt.released_by_process(log).values()):  # in every process
            break
        await asyncio.sleep(2.0)
    if log is not None:  # the trimmer's line once nothing is left (a checkout from before it logged: 15 s)
        await lt.all_released(log, trims, 15.0)
    fig.rss_closed = fig.sample(pid)
    built = [int(p) for p in BUILT.findall(log.read_text())] if log is not None else []
    if built:  # a checkout from before that log line: not known
        fig.pages = {worker: built.count(worker) for worker in fig.processes}
    return fig


def measure(opts, repo: Path, env: list[str], procs: str = "0") -> Figures:
    """The scenario against a server started from checkout ``repo`` with ``--num-procs procs`` and more environment
    ``env`` (``NAME=VALUE`` items), or against the running one of ``--url``."""
    proc = None
    url, pid, log = opts.url, opts.server_pid, opts.log
    if url is None:
        port = sc.free_port()
        log = Path(os.environ.get("TMPDIR", "/tmp")) / f"isl-classroom-{port}.log"
        proc = sc.start_server(
            port,
            log,
            ["--stats-interval", "1000", "--num-procs", procs, *opts.server_args.split()],
            repo=repo,
            env=dict(item.split("=", 1) for item in env),
        )
        sc.wait_healthy(port, 180, proc)
        url, pid = f"http://127.0.0.1:{port}", proc.pid
    try:
        return asyncio.run(scenario(url, pid, log, opts.students, opts.baseline, opts.duration))
    finally:
        if proc is not None:
            sc.stop_server(proc)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--students", type=int, default=40)
    p.add_argument("--baseline", type=float, default=60.0, help="seconds of students alone")
    p.add_argument("--duration", type=float, default=300.0, help="seconds with the heavy sessions")
    p.add_argument("--url"), p.add_argument("--server-pid", type=int)
    p.add_argument("--log", type=Path, help="the running server's log (with --stats-interval 1000)")
    p.add_argument("--server-args", default="", help="more options for the server this script starts")
    p.add_argument("--procs", default="0", help="--num-procs of the started server, one column each (0: per core)")
    p.add_argument("--before", type=Path, metavar="CHECKOUT", help="first measure a server of this other checkout")
    p.add_argument(
        "--env", action="append", default=[], metavar="NAME=VALUE", help="the started server's environment (repeatable)"
    )
    p.add_argument("--before-env", action="append", default=[], metavar="NAME=VALUE", help="the --before server's")
    opts = p.parse_args()
    if any("=" not in item for item in opts.env + opts.before_env):
        p.error("--env and --before-env take NAME=VALUE")
    if opts.before is not None and opts.url is not None:
        p.error("--before starts its own servers: it does not go with --url")
    procs = [v.strip() for v in opts.procs.split(",") if v.strip()]
    if not procs or not all(v.isdigit() for v in procs):
        p.error(f"--procs takes process counts (0: one per core) separated by commas, got {opts.procs!r}")
    columns = {}
    if opts.before is not None:
        columns["before"] = measure(opts, opts.before.resolve(), opts.before_env, procs[0])
    for count in procs:  # the timeline (ISL_TIMELINE) is the last column's
        TIMELINE.clear()
        name = "after" if opts.before is not None else {"0": "one per core", "1": "1 process"}.get(count, count)
        columns[name] = measure(opts, sc.REPO, opts.env, count)
    print(
        f"classroom scenario: {opts.students} students, baseline {opts.baseline:g} s, loaded {opts.duration:g} s "
        f"(load average {os.getloadavg()[0]:.2f}, {os.cpu_count()} cores)"
    )
    print(report(columns))
    for name, figures in columns.items():  # each error in full: its text carries the diagnosis
        for error in figures.errors:
            print(f"{name}: {error}")
    if os.environ.get("ISL_TIMELINE"):
        t0 = min(t for t, _, _ in TIMELINE)
        with open(os.environ["ISL_TIMELINE"], "w") as f:
            for t, what, dt in sorted(TIMELINE):
                f.write(f"{t - t0:8.3f} {what:20s} {1000 * dt:8.0f}\n")
    return 0 if not any(f.errors for f in columns.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
