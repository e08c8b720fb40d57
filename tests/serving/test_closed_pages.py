"""A closed session's page leaves the server's memory.

A few pages are opened as browsers open them (the page's HTML, then its websocket) and closed; once the server has
destroyed every session, run their release hooks and its full collection (the ``isl trim`` line with no session
left), none of those pages' documents may still be alive: the line's ``closed_pages`` counts the documents of ended
sessions still in memory among the ``pages_seen`` open at a look (:class:`app.serving.memory.MemoryTrimmer`). A page
kept after its session — its document, models, state and results, about 5 MB for a default page — is a leak a class
pays for page after page (:ref:`performance-memory-release`). The long jobs' thread, idle between jobs, must not
hold the last job either: its owner is a session's jobs, and through them the session's page.
"""

from __future__ import annotations

import asyncio
import gc
import re
import threading
import time
import weakref
from pathlib import Path

import pytest
from _serving import load_test, run, served, session_client

PAGES = 3
#: the trimmer's line once the class has left (scripts/load_test.py's memory options: it looks every 0.5 s)
LEFT = re.compile(r"isl trim: sessions=0 pending_releases=0 collected=True .* pages_seen=(\d+) closed_pages=(\d+)")


async def trimmed(log: Path, trims_before: int, sessions: int, timeout: float = 60.0) -> None:
    """Wait for a trimmer's line, after the first ``trims_before``, with ``sessions`` sessions left."""
    deadline = asyncio.get_running_loop().time() + timeout
    while sessions not in [left for left, _ in load_test.server_trims(log)[trims_before:]]:
        assert asyncio.get_running_loop().time() < deadline, log.read_text()[-3000:]
        await asyncio.sleep(0.1)


async def open_and_close(url: str, log: Path, pages: int) -> tuple[int, int]:
    """Open ``pages`` default pages and one more, close that one (the trimmer's line then reports every other page as
    seen open), then the others; ``(pages_seen, closed_pages)`` of the trimmer's line once none is left."""
    clients = [await session_client.open_page(url) for _ in range(pages + 1)]
    try:
        for client in clients:
            assert await client.widgets(), "a page showed no controls"
        trims = len(load_test.server_trims(log))
        await clients.pop().close()
        await trimmed(log, trims, pages)  # a look with the others open
    finally:
        trims = len(load_test.server_trims(log))
        await asyncio.gather(*(client.close() for client in clients))
    assert await load_test.all_released(log, trims, 60.0), log.read_text()[-3000:]
    found = LEFT.findall(log.read_text())
    assert found, log.read_text()[-3000:]
    seen, closed = map(int, found[-1])
    return seen, closed


@pytest.mark.slow
def test_no_page_of_a_closed_session_stays_in_memory(tmp_path):
    with served(tmp_path, *load_test.MEMORY_SERVER_ARGS, env={"PYTHONMALLOC": "malloc"}) as (url, _proc, log):
        seen, closed = run(open_and_close(url, log, PAGES), 300)
    assert seen >= PAGES, f"the trimmer saw {seen} of the {PAGES} pages open"
    assert closed == 0, f"{closed} of the {seen} closed pages are still in the server's memory"


class _Owner:
    """Stands for a session's jobs (a long job's owner holds the session's page)."""


def test_the_long_jobs_thread_lets_go_of_its_last_job_once_it_is_done():
    from app.jobs.long import LongJobQueue

    queue = LongJobQueue(workers=1)
    owner, delivered = _Owner(), threading.Event()
    alive = weakref.ref(owner)
    queue.submit(owner, lambda cancel: "table", lambda outcome: delivered.set(), lambda ahead: None)
    assert delivered.wait(10)
    del owner
    deadline = time.monotonic() + 5.0  # the thread goes back to wait for a job right after delivering this one
    while alive() is not None and time.monotonic() < deadline:
        gc.collect()
        time.sleep(0.01)
    assert alive() is None, "the queue's idle thread still holds the last job's owner"
