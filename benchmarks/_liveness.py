"""The classroom benchmark's liveness probe: ``/liveness`` fetched from a process of its own, so that the figure is
the server's answer time, not the benchmark's own event loop stalls."""

from __future__ import annotations

import asyncio
import multiprocessing
import time

__all__ = ["LivenessProbe", "probe_liveness"]


def probe_liveness(base: str, interval: float, stop, out) -> None:
    """In a process of its own: GET /liveness every ``interval`` s until ``stop`` is set; ``(t0, seconds or an
    error text, wall-clock t0)`` per probe go to ``out`` at the end. (Probed from the clients' event loop, the
    figure included that loop's own stalls — applying 44 sessions' patches in one Python process stalls it for up to
    0.8 s.)"""
    import urllib.request

    results = []
    while not stop.is_set():
        t0, wall = time.perf_counter(), time.time()
        try:
            with urllib.request.urlopen(f"{base}/liveness", timeout=30.0) as r:
                results.append((t0, time.perf_counter() - t0 if r.status == 200 else f"HTTP {r.status}", wall))
        except Exception as exc:  # noqa: BLE001
            results.append((t0, repr(exc), wall))
        stop.wait(interval)
    out.send(results)


class LivenessProbe:
    """``/liveness`` probed every 0.25 s from a separate process (:func:`probe_liveness`)."""

    def __init__(self, base: str, interval: float = 0.25) -> None:
        ctx = multiprocessing.get_context("spawn")
        self.stop, (self._recv, send) = ctx.Event(), ctx.Pipe(duplex=False)
        self.process = ctx.Process(target=probe_liveness, args=(base, interval, self.stop, send), daemon=True)
        self.process.start()
        self.answered: list[tuple[float, float]] = []  #: (wall-clock start, seconds) of each answered probe

    async def finish(self, figures, timeline: list) -> None:
        """Stop probing; each probe's seconds go to ``figures.liveness`` and ``timeline``, an error to
        ``figures.errors``."""
        self.stop.set()
        results = await asyncio.get_running_loop().run_in_executor(None, self._recv.recv)
        self.process.join(10)
        for t0, outcome, wall in results:
            if isinstance(outcome, str):
                figures.errors.append(f"liveness: {outcome}")
            else:
                figures.liveness.append(outcome)
                self.answered.append((wall, outcome))
                timeline.append((t0, "liveness", outcome))
