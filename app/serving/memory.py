"""The served dashboard's memory: closed sessions' garbage collected when it is cheap, freed heap handed back.

:mod:`app.serving.serve` starts a :class:`MemoryTrimmer` and calls :func:`quiet_garbage_collection` from Panel's
``customize_server`` hook; :func:`log_stats` writes the periodic ``isl stats`` line.
"""
from __future__ import annotations

import ctypes
import gc
import logging
import os

log = logging.getLogger("isl.serve")

#: the allocator that hands a class's memory back (opt-in, set before Python starts; see :func:`check_allocator`)
ALLOCATOR_ENV = ("PYTHONMALLOC", "malloc")
# How often to check whether sessions have ended and, if so, hand freed heap memory back to the OS.
TRIM_INTERVAL_MS = 5_000
#: at most this many sessions left: a full garbage collection may run (:class:`MemoryTrimmer`). Not 1: a full
#: collection while one session was open lost that session's next update now and then (a browser test ticking four
#: filters waited 60 s for data in 1 of 3 runs, and in CI; with 0, 9 of 9 runs passed) — the cause is not found.
QUIET_SESSIONS = 0


def rss_mb() -> float:
    """Resident memory of this process in MB (Linux ``/proc``; nan elsewhere)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (OSError, ValueError, IndexError):
        return float("nan")


def log_stats(server) -> None:
    """One ``isl stats`` line: live sessions, open connections, sessions whose release hooks have not run yet
    (:func:`app.hardening.release_on_destroy`), resident memory of this process."""
    from app.serving import hardening

    sessions = server.get_sessions()
    connections = sum(s.connection_count for s in sessions)
    log.info("isl stats: sessions=%d connections=%d pending_releases=%d rss_mb=%.1f", len(sessions), connections,
             hardening.live_release_hooks(), rss_mb())


class MemoryTrimmer:
    """Collect closed sessions' garbage and return freed heap memory to the OS, when it is cheap to.

    Every ``TRIM_INTERVAL_MS``, if sessions have ended or their release hooks have run since the last look: with
    at most :data:`QUIET_SESSIONS` sessions left (none), a full garbage collection; then glibc's ``malloc_trim`` (a no-op elsewhere). Sessions are built
    and updated on worker threads, so their memory lives in per-thread malloc arenas that glibc does not shrink by
    itself: without trimming, the RSS of a server stays at the peak of its busiest class.

    Why not a full collection at every session's end, as Panel schedules one: a full collection walks every object
    of the heap while holding the interpreter lock, whichever thread runs it — 146 ms for the idle server's 230 000
    objects on this machine, and more for every open session's objects — so it stopped the event loop each time a
    student closed a tab (py-spy, classroom scenario: 3 % of the loop's busy samples were Panel's ``gc.collect``).
    During a class, Python's own generational collector frees closed sessions' cycles (its oldest generation is
    collected once it has grown by 25 %); when the class has left, the collection here returns the memory.
    """

    def __init__(self, server) -> None:
        self.server, self.sessions = server, 0
        try:
            self._trim = ctypes.CDLL("libc.so.6").malloc_trim
        except (OSError, AttributeError):
            self._trim = None

    def __call__(self) -> None:
        from app.serving import hardening

        sessions, pending = len(self.server.get_sessions()), hardening.live_release_hooks()
        # a session's memory is free once it has ended *and* its release hooks have run: trim after either
        if sessions + pending < self.sessions:
            collected = sessions <= QUIET_SESSIONS
            if collected:
                gc.collect()
            if self._trim is not None:
                self._trim(0)
            # the event a memory measurement waits for (scripts/load_test.py), instead of a guess at the interval
            log.info("isl trim: sessions=%d pending_releases=%d collected=%s rss_mb=%.1f", sessions, pending,
                     collected, rss_mb())
        self.sessions = sessions + pending


def check_allocator() -> bool:
    """Whether Python's small objects come from the C allocator (``PYTHONMALLOC=malloc``); one log line if not.

    Python's own small-object allocator takes memory in 1 MiB arenas and returns an arena only when every object in
    it is gone. A class leaves a few hundred long-lived objects (caches filled by the first sessions, interned names)
    scattered over the arenas its sessions used, and those pin them: with 40 sessions opened and closed, the server's
    RSS stayed at 475–517 MB against 346 MB idle (no Python object of the sessions was left, and ``malloc_trim`` ran).
    With ``PYTHONMALLOC=malloc`` the same objects come from glibc, whose freed pages ``malloc_trim`` returns: 364–365
    MB after each of two rounds, against 353 MB idle. The price is the event loop's time: glibc's allocator is slower
    for Python's small objects (serializing the page 97–113 → 131–136 ms, re-walking its models 23–29 → 30–35 ms;
    in the classroom scenario, one run each, ``/liveness`` p99 0.93 → 1.71 s and RSS after close 1.77 → 1.18 × idle).
    A class's responsiveness comes first, so it is opt-in (read when Python starts: set it in the environment); what
    stays without it is a plateau — a second and third class do not add to it — not a leak. One log line says which.
    """
    name, value = ALLOCATOR_ENV
    chosen = os.environ.get(name) == value
    log.info("memory: %s (%s=%s %s)", "glibc's allocator: closed sessions' memory goes back" if chosen else
             "Python's allocator: the memory a class used stays for the next one", name, value,
             "set" if chosen else "hands it back, for a slower event loop")
    return chosen


def quiet_garbage_collection() -> None:
    """The collector's part of serving (see :class:`MemoryTrimmer`): what exists once the app is warm (modules,
    the warm-up's caches: ≈ 230 000 objects, 146 ms a full collection on this machine) is frozen out of every later
    collection, and Panel's full collection after each session's end is left to :class:`MemoryTrimmer`."""
    import panel.io.document as panel_document

    panel_document._garbage_collect = lambda: None
    gc.collect()
    gc.freeze()
