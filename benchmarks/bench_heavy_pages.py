"""Three heavy pages in chromium beside a default page: how long ``/liveness`` waits.

    PYTHONPATH=. python benchmarks/bench_heavy_pages.py [--duration 300] [--procs 1,0] [--before CHECKOUT]

Starts ``python -m app.serving`` on a free loopback port, once per ``--procs`` value (one column each: 1 process,
then the default, one per core), and opens in Debian's chromium (Playwright), as a class's browsers would:

* two pages at ``HEAVY`` (m = 6, ν = 10⁴, horizon 1000, every extra filter: ≈ 10⁶ steps a run), each pressing
  "new noise" again as soon as BokehJS holds its new run's data;
* one page on the worst case's tab at its maximum (m = 6, 11 σ, horizon 2000), pressing Compute again as soon as a
  table or a refusal is shown;
* a default page, opened again every 30 s (ready: its first plot's data in BokehJS),

for ``--duration`` seconds, while ``/liveness`` is probed every 0.25 s from a process of its own
(:mod:`_liveness`). Prints ``/liveness`` p50 / p99 / max, what the heavy pages got done, the default page's ready
times and every error (a page's script error included). The aim: ``/liveness`` max ≤ 0.5 s. The load average is
printed: figures compare only on an otherwise idle machine.

Each probe that waited :data:`LATE_S` or more is printed with the stalls the server logged over its wait
(:mod:`app.serving.stalls`: which process's loop, how long, running / waiting for a core / blocked, and where its
thread was); ``--stall-log MS`` sets the server's threshold (default 100 ms). With ``--before CHECKOUT`` (a
checkout of an older commit) its servers run first, then this one's, in one run: one column each. With
``--browser-nice N`` chromium runs N steps lower in CPU priority than the server: in a class the browsers are on
other machines, and here their drawing competes with the server's loop for the same two cores.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import statistics
import sys
import time
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import session_client as sc
from _liveness import LivenessProbe

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from app.serving import stalls as stall_log

HEAVY = (
    "alpha=1&w=1&sigma=1&m=6&nu=10000&horizon=1000"
    '&extra_filters=["kbf_mismatched","kbf_minimax","kbf_adaptive","isl_model"]'
)
WORST = "m=6&wc_n_sigma=11&wc_horizon=2000&tab=worstcase"
CHROMIUM = "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]
REOPEN_S = 30.0  #: the default page is opened again this often
LATE_S = 0.25  #: a probe that waited this long is printed with the stalls that made it wait
#: the first plot's first values as BokehJS holds them ('' while it has none)
RUN = """() => { try { const s = Bokeh.documents[0].get_model_by_name('traj-1-isl');
                       return s ? Array.from(s.data.y.slice(0, 8)).join(',') : ''; } catch (e) { return ''; } }"""
#: a new run's data: the first values differ from ``before`` (and exist)
NEW_RUN = f"(before) => {{ const now = ({RUN})(); return now !== '' && now !== before; }}"
#: the texts of the page's HTML and Markdown panes, as BokehJS holds them
TEXTS = """() => { try { return Array.from(Bokeh.documents[0]._all_models.values())
    .filter(m => typeof m.text === 'string').map(m => m.text); } catch (e) { return []; } }"""
#: a worst-case answer: a pane's text that was not among ``before`` says it finished, failed or was refused
ANSWERED = f"""(before) => ({TEXTS})().some(t => !before.includes(t)
    && /Simulated in|Failed|Refused|refused|Cancelled/.test(t))"""


@dataclass
class Figures:
    errors: list[str] = field(default_factory=list)
    liveness: list[float] = field(default_factory=list)
    runs: int = 0
    answers: int = 0
    ready: list[float] = field(default_factory=list)
    probes: list[tuple[float, float]] = field(default_factory=list)  #: (wall-clock start, seconds) answered
    stalls: list[tuple[float, stall_log.Stall]] = field(default_factory=list)  #: (wall-clock end, stall) logged


async def open_page(browser, url: str, figures: Figures, what: str):
    page = await browser.new_page(viewport={"width": 1600, "height": 1000})
    page.on("pageerror", lambda error: figures.errors.append(f"{what}: script error {error}"))
    await page.goto(url)
    return page


async def new_noise(browser, base: str, figures: Figures) -> None:
    """A heavy page: "new noise" again each time its run's data has reached BokehJS."""
    page = await open_page(browser, f"{base}/app?{HEAVY}", figures, "heavy")
    await page.wait_for_function(f"() => ({RUN})() !== ''", timeout=300_000, polling=100)
    while True:
        before = await page.evaluate(RUN)
        await page.get_by_role("button", name="new noise").click()
        await page.wait_for_function(NEW_RUN, arg=before, timeout=300_000, polling=50)
        figures.runs += 1


async def worst_case(browser, base: str, figures: Figures) -> None:
    """A worst-case page at its maximum: Compute again each time a table or a refusal is shown."""
    page = await open_page(browser, f"{base}/app?{WORST}", figures, "worst case")
    compute = page.get_by_role("button", name="Compute")
    await compute.wait_for(timeout=300_000)
    while True:
        before = await page.evaluate(TEXTS)
        await compute.click()
        await page.wait_for_function(ANSWERED, arg=before, timeout=900_000, polling=250)
        figures.answers += 1


async def default_pages(browser, base: str, figures: Figures) -> None:
    """A default page, opened again every :data:`REOPEN_S` s: seconds from opening to its first run's data."""
    page = None
    while True:
        t0 = time.perf_counter()
        if page is not None:
            await page.close()
        page = await open_page(browser, f"{base}/app", figures, "default")
        await page.wait_for_function(f"() => ({RUN})() !== ''", timeout=120_000, polling=50)
        figures.ready.append(time.perf_counter() - t0)
        await asyncio.sleep(max(0.0, t0 + REOPEN_S - time.perf_counter()))  # a pace, not a wait for an event


def browser_at(nice: int) -> str:
    """Debian's chromium, or a script that starts it ``nice`` steps below this process's CPU priority (its renderers
    inherit it): in a class the browsers run on the students' machines, here on the server's cores."""
    if nice <= 0:
        return CHROMIUM
    import tempfile

    fd, path = tempfile.mkstemp(prefix="isl-chromium-", suffix=".sh")
    with os.fdopen(fd, "w") as f:
        f.write(f'#!/bin/sh\nexec nice -n {nice} {CHROMIUM} "$@"\n')
    os.chmod(path, 0o700)
    return path


async def scenario(base: str, duration: float, browser_nice: int = 0) -> Figures:
    from playwright.async_api import async_playwright

    figures = Figures()
    async with async_playwright() as p:
        executable = browser_at(browser_nice)
        browser = await p.chromium.launch(executable_path=executable, args=ARGS)
        if executable != CHROMIUM:
            os.unlink(executable)  # started: the script is no longer needed
        probe = LivenessProbe(base)
        tasks = [asyncio.ensure_future(new_noise(browser, base, figures)) for _ in range(2)]
        tasks += [asyncio.ensure_future(worst_case(browser, base, figures))]
        tasks += [asyncio.ensure_future(default_pages(browser, base, figures))]
        done, _ = await asyncio.wait(tasks, timeout=duration, return_when=asyncio.FIRST_EXCEPTION)
        for task in tasks:
            if task in done and task.exception() is not None:
                figures.errors.append(f"page: {task.exception()!r}"[:300])
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        await probe.finish(figures, [])
        figures.probes = probe.answered
        await browser.close()
    return figures


def logged_stalls(log: Path) -> list[tuple[float, stall_log.Stall]]:
    """Every stall in the server's log, with the wall-clock time its line was written (the stall's end)."""
    found = []
    for line in log.read_text(errors="replace").splitlines():
        stall = stall_log.parse(line)
        if stall is not None:
            try:
                end = datetime.strptime(line[:23], "%Y-%m-%d %H:%M:%S,%f").timestamp()
            except ValueError:
                continue
            found.append((end, stall))
    return found


def measure(procs: str, duration: float, stall_ms: int, repo: Path | None = None, browser_nice: int = 0) -> Figures:
    """One column: the server of checkout ``repo`` (default: this one) with ``--num-procs procs``."""
    port = sc.free_port()
    log = Path(os.environ.get("TMPDIR", "/tmp")) / f"isl-heavy-pages-{port}.log"
    repo = (repo or sc.REPO).resolve()
    logs_stalls = (repo / "app" / "serving" / "stalls.py").is_file()  # an older checkout has no --stall-log
    extra = ["--num-procs", procs] + (["--stall-log", str(stall_ms)] if logs_stalls else [])
    proc = sc.start_server(port, log, extra, repo=repo)
    try:
        sc.wait_healthy(port, 180, proc)
        figures = asyncio.run(scenario(f"http://127.0.0.1:{port}", duration, browser_nice))
    finally:
        sc.stop_server(proc)
    figures.stalls = logged_stalls(log)
    return figures


def late_probes(f: Figures) -> list[str]:
    """Each probe that waited :data:`LATE_S` or more, with the stalls logged over its wait (or none found)."""
    if not f.probes:
        return []
    first = min(wall for wall, _ in f.probes)
    lines = []
    for wall, seconds in f.probes:
        if seconds < LATE_S:
            continue
        over = [
            stall
            for end, stall in f.stalls
            if end - stall.ms / 1000 - 0.05 <= wall + seconds and end + 0.05 >= wall  # overlapping its wait
        ]
        lines.append(f"  probe at {wall - first:6.1f} s waited {1000 * seconds:.0f} ms")
        lines += [f"    process {s.pid}: loop stalled {s.ms:.0f} ms: {s.detail}" for s in over]
        if not over:
            lines.append("    no stall logged over its wait (the probe's own connection, or below --stall-log)")
    return lines


def pct(data: list[float], q: float) -> float:
    return sorted(data)[min(len(data) - 1, int(q * len(data)))] if data else float("nan")


def rows(f: Figures) -> dict[str, str]:
    ms = lambda x: f"{1000 * x:.0f} ms"  # noqa: E731
    return {
        "errors": str(len(f.errors)),
        "/liveness p50 / p99 / max (probes)": f"{ms(pct(f.liveness, 0.5))} / {ms(pct(f.liveness, 0.99))} / "
        f"{ms(pct(f.liveness, 1.0))} ({len(f.liveness)})",
        "heavy runs drawn / worst-case answers": f"{f.runs} / {f.answers}",
        "default page ready, median / max (pages)": f"{statistics.median(f.ready) if f.ready else float('nan'):.2f}"
        f" / {max(f.ready, default=float('nan')):.2f} s ({len(f.ready)})",
    }


def report(columns: dict[str, Figures]) -> str:
    """One row per figure, one column per server."""
    table = {name: rows(f) for name, f in columns.items()}
    names = list(next(iter(table.values())))
    width = max(len(row) for row in names)
    cells = {name: max(len(name), *(len(v) for v in t.values())) for name, t in table.items()}
    lines = [f"{'':<{width}}  " + "  ".join(f"{name:<{cells[name]}}" for name in table)]
    for row in names:
        lines.append(f"{row:<{width}}  " + "  ".join(f"{t[row]:<{cells[name]}}" for name, t in table.items()))
    return "\n".join(lines)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--duration", type=float, default=300.0, help="seconds the pages run (default 300)")
    p.add_argument("--procs", default="1,0", help="--num-procs of each server, comma-separated (0: one per core)")
    p.add_argument("--stall-log", type=int, default=100, metavar="MS", help="the servers' stall threshold (ms)")
    p.add_argument(
        "--browser-nice",
        type=int,
        default=0,
        metavar="N",
        help="run chromium N steps lower in CPU priority (default 0)",
    )
    p.add_argument("--before", type=Path, help="a checkout of an older commit: its columns first, in the same run")
    opts = p.parse_args()
    procs = [v.strip() for v in opts.procs.split(",") if v.strip()]
    if not procs or not all(v.isdigit() for v in procs):
        p.error(f"--procs takes process counts (0: one per core) separated by commas, got {opts.procs!r}")
    names = {"0": "one per core", "1": "1 process"}
    checkouts = [("before, ", opts.before), ("after, ", None)] if opts.before else [("", None)]
    columns = {
        f"{label}{names.get(n, n)}": measure(n, opts.duration, opts.stall_log, repo, opts.browser_nice)
        for label, repo in checkouts
        for n in procs
    }
    print(
        f"three heavy pages and a default page in chromium (nice +{opts.browser_nice}), {opts.duration:g} s "
        f"(load average {os.getloadavg()[0]:.2f}, {os.cpu_count()} cores)"
    )
    print(report(columns))
    for name, f in columns.items():
        for error in f.errors:
            print(f"{name}: {error}")
        late = late_probes(f)
        if late:
            print(f"{name}: probes that waited {1000 * LATE_S:.0f} ms or more, and the stalls over their wait")
            print("\n".join(late))
        print(f"{name}: {len(f.stalls)} stalls logged, {sum(s.ms for _, s in f.stalls) / 1000:.1f} s in all")
    return 0 if not any(f.errors for f in columns.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
