"""The served dashboard's memory: closed sessions' garbage collected when it is cheap, freed heap handed back.

:mod:`app.serving.serve` starts a :class:`MemoryTrimmer` and calls :func:`freeze_warm_heap` from Panel's
``customize_server`` hook; :func:`log_stats` writes the periodic ``isl stats`` line.
"""

from __future__ import annotations

import ctypes
import gc
import logging
import os
import time
import weakref
from collections.abc import Callable
from typing import Any

log = logging.getLogger("isl.serve")

#: the allocator that hands a class's memory back (set by scripts/serve and the image; see :func:`check_allocator`)
ALLOCATOR_ENV = ("PYTHONMALLOC", "malloc")
# How often to check whether sessions have ended and, if so, hand freed heap memory back to the OS.
TRIM_INTERVAL_MS = 5_000
#: at most this many sessions left: a full garbage collection may run (:class:`MemoryTrimmer`). Not 1: a full
#: collection while one session was open lost that session's next update now and then; the cause is not found
#: (:ref:`performance-memory-release`).
QUIET_SESSIONS = 0
#: sessions ended since the last full collection after which one runs even with sessions open (frozen objects of
#: ended sessions, in reference cycles, are only freed by a full collection; see :func:`young_then_freeze`)
FULL_AFTER_ENDED = 40


def rss_mb() -> float:
    """Resident memory of this process in MB (Linux ``/proc``; nan elsewhere)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (OSError, ValueError, IndexError):
        return float("nan")


class CollectorPauses:
    """How long Python's garbage collector held the interpreter, per generation, since the last look.

    A collection stops every thread, the event loop's included, for as long as it walks its generation: what a
    ``/liveness`` probe or a slider's update waits for while one runs. Read by :func:`log_stats`."""

    def __init__(self) -> None:
        self._start = 0.0
        self.count, self.total, self.longest = [0, 0, 0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
        gc.callbacks.append(self)

    def __call__(self, phase: str, info: dict) -> None:
        if phase == "start":
            self._start = time.perf_counter()
            return
        g, took = info["generation"], time.perf_counter() - self._start
        self.count[g] += 1
        self.total[g] += took
        self.longest[g] = max(self.longest[g], took)

    def take(self) -> str:
        """``gen=count/total ms/longest ms`` for each generation, then start counting afresh."""
        text = " ".join(
            f"gc{g}={self.count[g]}/{self.total[g] * 1e3:.0f}/{self.longest[g] * 1e3:.0f}ms" for g in range(3)
        )
        self.count, self.total, self.longest = [0, 0, 0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
        return text


PAUSES = CollectorPauses()


def log_stats(server) -> None:
    """One ``isl stats`` line: live sessions, open connections, sessions whose release hooks have not run yet
    (:func:`app.serving.session.release_on_destroy`), resident memory of this process, and the garbage collector's
    pauses since the last line (:class:`CollectorPauses`: collections, their total and longest time, per
    generation)."""
    from app.serving import session

    sessions = server.get_sessions()
    connections = sum(s.connection_count for s in sessions)
    log.info(
        "isl stats: sessions=%d connections=%d pending_releases=%d rss_mb=%.1f %s pid=%d",
        len(sessions),
        connections,
        session.live_release_hooks(),
        rss_mb(),
        PAUSES.take(),
        os.getpid(),  # one server process of several: which one
    )


class MemoryTrimmer:
    """Collect closed sessions' garbage and return freed heap memory to the OS, when it is cheap to.

    Every ``TRIM_INTERVAL_MS``, if sessions have ended or their release hooks have run since the last look: with
    at most :data:`QUIET_SESSIONS` sessions left (none), or once :data:`FULL_AFTER_ENDED` sessions have ended since
    the last one, a full garbage collection (:func:`full_collection`); then glibc's ``malloc_trim`` (a no-op
    elsewhere). Sessions are built and updated on worker threads, so their memory lives in per-thread malloc arenas
    that glibc does not shrink by itself: without trimming, the RSS of a server stays at the peak of its busiest
    class. Without a full collection (no session has ended, or a class is still open), the young generations are
    collected and what has lived so far is frozen (:func:`young_then_freeze`).

    Why so: a full collection walks every object of the heap while holding the interpreter lock, whichever thread
    runs it, and the event loop, ``/liveness`` and every student's update wait for it; the heap of a server with a
    class open takes long to walk (:ref:`performance-serving`). Panel schedules one (``gc.collect()``) after every
    session's end, and Python's own collector runs one whenever its oldest generation has grown by 25 %, which a class
    opening its pages does often. Frozen objects are not walked, so these collections walk only what is new since
    the last look; a closed session's objects that hold each other in cycles are freed by the next full collection:
    when the class has left, or after :data:`FULL_AFTER_ENDED` sessions have ended. When no session is left the core's
    caches are emptied first (:func:`isl_core.clear_caches`): what a class computed goes with it
    (:ref:`performance-memory-release`). The ``isl trim`` line counts the pages (bokeh documents) of the sessions seen
    open at a look, and those of them still in memory after their session ended (:meth:`closed_pages`).
    """

    def __init__(self, server) -> None:
        self.server, self.sessions, self.ended = server, 0, 0
        #: the documents of the sessions open at each look, weakly held: one still alive after its session has ended
        #: and a full collection has run is a closed page something holds — a leak (``closed_pages`` in the
        #: ``isl trim`` line; :ref:`performance-memory-release`)
        self.pages: weakref.WeakSet = weakref.WeakSet()
        self.seen = 0  #: how many documents the looks have seen in all (``pages_seen``)
        self._trim: Callable[[int], Any] | None  # glibc's malloc_trim, None elsewhere
        try:
            self._trim = ctypes.CDLL("libc.so.6").malloc_trim
        except (OSError, AttributeError):
            self._trim = None

    def __call__(self) -> None:
        from app.serving import session

        live = self.server.get_sessions()
        open_pages = _documents(live)
        for doc in open_pages:
            if doc not in self.pages:
                self.pages.add(doc)
                self.seen += 1
        sessions, pending = len(live), session.live_release_hooks()
        # a session's memory is free once it has ended *and* its release hooks have run: trim after either
        if sessions + pending < self.sessions:
            self.ended += self.sessions - (sessions + pending)
            collected = sessions <= QUIET_SESSIONS or self.ended >= FULL_AFTER_ENDED
            if collected:
                if sessions <= QUIET_SESSIONS:  # the class has left: what it computed goes too
                    import isl_core  # (here: importing it configures numba's cache, after serve's logging)

                    isl_core.clear_caches()
                full_collection()
                self.ended = 0
            else:
                young_then_freeze()  # Panel's collection after these sessions' end walks only what comes next
            if self._trim is not None:
                self._trim(0)
            # the event a memory measurement waits for (scripts/load_test.py), instead of a guess at the interval
            log.info(
                "isl trim: sessions=%d pending_releases=%d collected=%s rss_mb=%.1f pages_seen=%d closed_pages=%d"
                " pid=%d",
                sessions,
                pending,
                collected,
                rss_mb(),
                self.seen,
                self.closed_pages(open_pages),
                os.getpid(),  # one server process of several: which one
            )
        else:
            young_then_freeze()
        self.sessions = sessions + pending

    def closed_pages(self, open_pages: list) -> int:
        """How many documents of ended sessions are still in memory, ``open_pages`` being those of the sessions open
        now (of those seen at a look: a session opened and closed between two looks is not counted). Right after a
        full collection, any is held by something."""
        still_open = set(open_pages)
        return sum(1 for doc in list(self.pages) if doc not in still_open)


def _documents(sessions) -> list:
    """The documents of bokeh's server sessions (a stand-in session without one, as the unit tests pass, has none)."""
    return [doc for s in sessions if (doc := getattr(s, "document", None)) is not None]


def full_collection() -> None:
    """Every object, frozen or not, collected; then what is left frozen out of later collections."""
    gc.unfreeze()
    gc.collect()
    gc.freeze()


def young_then_freeze() -> None:
    """The young generations collected (their garbage: tens of ms at most), then every object that has lived so far
    frozen out of the collector's later walks (an O(1) move), so that its oldest generation holds only what is new
    since the last look, and no automatic collection walks a class's whole heap while it holds the interpreter and
    with it the event loop (``isl stats``'s ``gc2``; :ref:`performance-serving`)."""
    gc.collect(1)
    gc.freeze()


def check_allocator() -> bool:
    """Whether Python's small objects come from the C allocator (``PYTHONMALLOC=malloc``); one log line says which.

    Python's own small-object allocator takes memory in 1 MiB arenas and returns an arena only when every object in
    it is gone. A class leaves a few hundred long-lived objects (caches filled by the first sessions, interned names)
    scattered over the arenas its sessions used, and those pin them, even with no Python object of the sessions left
    and ``malloc_trim`` run. With ``PYTHONMALLOC=malloc`` the same objects come from glibc, whose freed pages
    ``malloc_trim`` returns. glibc's allocator is slower for Python's small objects, a small price since pages are
    built off the event loop (:ref:`performance-memory`). So ``./scripts/serve`` and the image set it (Python reads
    it at start: an environment setting); ``PYTHONMALLOC=pymalloc`` keeps Python's allocator (memory then stays at a
    plateau for the next class: not a leak).
    """
    name, value = ALLOCATOR_ENV
    chosen = os.environ.get(name) == value
    log.info(
        "memory: %s (%s=%s %s)",
        "glibc's allocator: closed sessions' memory goes back"
        if chosen
        else "Python's allocator: the memory a class used stays for the next one",
        name,
        value,
        "set" if chosen else "hands it back (scripts/serve and the image set it)",
    )
    return chosen


def freeze_warm_heap() -> None:
    """What exists once the app is warm (modules, the warm-up's caches) collected once, then frozen out of every later
    collection (Python's ``gc.freeze``): a collection — Panel's after each session's end, Python's automatic ones —
    walks only what is newer (see :class:`MemoryTrimmer`, which freezes again at each look)."""
    gc.collect()
    gc.freeze()
