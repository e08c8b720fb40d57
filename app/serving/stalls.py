"""Stalls of the event loop, logged with what the loop's thread was doing and why it did not answer.

The event loop answers every session of a process and ``/liveness``; when it does not answer for a while, the
question is what held it. :class:`StallWatch` puts a heartbeat on the loop (a callback every :data:`BEAT_S`) and a
watcher thread beside it. Once a beat is late, the watcher samples the loop thread's Python stack every
:data:`SAMPLE_S`; when the beats resume after a stall of at least ``threshold`` seconds it logs one line
(``isl.stall``, a warning) with

* how long the loop did not answer, in which process;
* how that time splits, from the kernel's own accounts of the loop's thread (``/proc/self/task/TID/schedstat``,
  read by the watcher at each of its looks, so the split starts at most :data:`BEAT_S` before the stall):
  *running* (the thread ran on a core: it was busy with the work its stack shows), *waiting for a core* (runnable
  but not scheduled: the machine's cores were all taken), and the rest, *blocked* (asleep in the kernel: waiting for
  the interpreter lock, another lock, or I/O);
* the stack the loop thread was seen at most often (innermost frames first) and in how many samples;
* how late the watcher itself woke (it needs the interpreter lock to sample: a late watcher means some thread held
  the lock, or the cores were taken), and where the other threads of the process that were not waiting were seen
  most often when it woke late (the thread that held the lock is then still at the line that held it).

The heartbeat costs the loop one callback every :data:`BEAT_S`; the watcher wakes every :data:`BEAT_S` too and
samples only during a late beat. :func:`parse` reads such a line back (the heavy-pages benchmark matches a late
``/liveness`` probe to the stall that made it late).
"""

from __future__ import annotations

import logging
import os
import re
import sys
import threading
import time
import types
from collections import Counter
from dataclasses import dataclass

__all__ = ["BEAT_S", "SAMPLE_S", "Stall", "StallWatch", "parse", "watch"]

log = logging.getLogger("isl.stall")

BEAT_S = 0.05  #: the heartbeat's period on the loop, and the watcher's between looks
SAMPLE_S = 0.005  #: the watcher's period while a beat is late
FRAMES = 4  #: innermost frames of the loop thread's stack named with their file and line in a stall's line
CALLERS = 8  #: and the functions that called them, by name
LATE_WAKE_S = 0.02  #: a watcher's wake-up this late samples the other threads too
#: innermost functions of a thread that waits (for work, a lock, a child process, a socket): not what held the loop
IDLE = re.compile(r"^(wait|_wait_for_tstate_lock|select|poll|_poll|accept|recv_bytes|_recv|get|_worker|sleep) \(")
PREFIX = "isl loop stalled"


def _schedstat(tid: int) -> tuple[float, float]:
    """Seconds the thread ``tid`` of this process has run and waited runnable for a core (0, 0 where unknown)."""
    try:
        with open(f"/proc/self/task/{tid}/schedstat") as f:
            run_ns, wait_ns = f.read().split()[:2]
        return int(run_ns) * 1e-9, int(wait_ns) * 1e-9
    except (OSError, ValueError):
        return 0.0, 0.0


def _where(frame, depth: int = FRAMES, callers: int = CALLERS) -> str:
    """``func (file:line) < caller (file:line) … < outer < outer`` for the innermost ``depth`` frames of ``frame``
    and the names of the ``callers`` frames out from them.

    The frames are another thread's, read while that thread may run (the watcher can lose the interpreter lock between
    two steps), and CPython 3.11 then once gave a ``cell`` object as a frame's ``f_back``: the walk ends at the first
    object that is not a frame, with what it has named so far."""
    names: list[str] = []
    while isinstance(frame, types.FrameType) and len(names) < depth + callers:
        code = frame.f_code
        where = f" ({os.path.basename(code.co_filename)}:{frame.f_lineno})" if len(names) < depth else ""
        names.append(code.co_name + where)
        frame = frame.f_back
    return " < ".join(names)


class StallWatch:
    """The heartbeat on ``loop`` (an asyncio loop) and its watcher thread (module docstring); :meth:`start` once."""

    def __init__(self, loop, threshold: float) -> None:
        self.loop, self.threshold = loop, threshold
        self.beat = time.monotonic()
        self.tid = 0  # the loop thread's ids, known at its first beat
        self.ident = 0
        self.stalls = 0  #: stalls logged so far (for tests)

    def start(self) -> None:
        self.loop.call_soon_threadsafe(self._beat)
        threading.Thread(target=self._watch, name="isl-stall-watch", daemon=True).start()

    def _beat(self) -> None:
        self.tid, self.ident = threading.get_native_id(), threading.get_ident()
        self.beat = time.monotonic()
        self.loop.call_later(BEAT_S, self._beat)

    def _watch(self) -> None:
        baseline = (0.0, 0.0)
        while True:
            t = time.monotonic()
            time.sleep(BEAT_S)
            woke = time.monotonic() - t - BEAT_S  # how late the watcher itself came
            if time.monotonic() - self.beat > 2 * BEAT_S and self.tid:
                try:
                    self._sample(baseline, woke)
                except Exception:  # the watcher must outlive a stall it could not describe
                    log.exception("could not describe a stall of the event loop")
            # the loop thread's accounts at most BEAT_S before a stall begins: a stall the watcher itself saw late
            # (it needs the interpreter lock too) is still split from its start
            baseline = _schedstat(self.tid) if self.tid else baseline

    def _sample(self, baseline: tuple[float, float], woke: float) -> None:
        """Sample the loop thread while its beat is late; log the stall if it lasted ``threshold``."""
        began = self.beat
        run0, wait0 = baseline
        seen: Counter[str] = Counter()
        others: Counter[str] = Counter()
        late = max(0.0, woke)
        while self.beat == began:
            frames = sys._current_frames()
            frame = frames.pop(self.ident, None)
            if frame is not None:
                seen[_where(frame)] += 1
            if woke >= LATE_WAKE_S:
                others.update(_busy(frames))
            del frame, frames
            t = time.monotonic()
            time.sleep(SAMPLE_S)
            woke = time.monotonic() - t - SAMPLE_S
            late = max(late, woke)
        stalled = self.beat - began - BEAT_S
        if stalled < self.threshold:
            return
        run1, wait1 = _schedstat(self.tid)
        running, waiting = run1 - run0, wait1 - wait0
        top, count = seen.most_common(1)[0] if seen else ("(not sampled)", 0)
        self.stalls += 1
        log.warning(
            "%s %.0f ms in process %d: running %.0f ms, waiting for a core %.0f ms, blocked %.0f ms; "
            "at %s (%d of %d samples); watcher woke up to %.0f ms late%s",
            PREFIX,
            1e3 * stalled,
            os.getpid(),
            1e3 * running,
            1e3 * waiting,
            1e3 * max(0.0, stalled - running - waiting),
            top,
            count,
            sum(seen.values()),
            1e3 * late,
            "".join(f"; {where} ({n})" for where, n in others.most_common(2)),
        )


def _busy(frames: dict) -> list[str]:
    """``thread-name: stack`` of each thread in ``frames`` (``sys._current_frames()``) that is not waiting."""
    names = {t.ident: t.name for t in threading.enumerate()}
    found = []
    for ident, frame in frames.items():
        if ident != threading.get_ident():
            where = _where(frame, 3, 3)
            if not IDLE.match(where):
                found.append(f"{names.get(ident, ident)}: {where}")
    return found


def watch(loop, threshold: float) -> StallWatch | None:
    """Start a :class:`StallWatch` on ``loop`` logging stalls of ``threshold`` seconds or more (None if ≤ 0)."""
    if threshold <= 0:
        return None
    watcher = StallWatch(loop, threshold)
    watcher.start()
    return watcher


@dataclass(frozen=True)
class Stall:
    """One logged stall: its process, how long, and the text after the duration."""

    pid: int
    ms: float
    detail: str


_LINE = re.compile(rf"{PREFIX} (\d+) ms in process (\d+): (.*)$")


def parse(line: str) -> Stall | None:
    """The :class:`Stall` a log line reports, or None if it reports none."""
    found = _LINE.search(line.rstrip())
    return Stall(int(found.group(2)), float(found.group(1)), found.group(3)) if found else None
