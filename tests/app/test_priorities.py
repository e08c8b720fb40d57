"""The server's threads take the cores in a stated order: the event loop first, then the page builds, the runs, the
large runs and the long jobs (``app.jobs.base``: each pool's threads set their own priority as they start, below the
process's)."""

from __future__ import annotations

import os
import sys
import threading
from concurrent.futures import ThreadPoolExecutor

import pytest

from app.jobs import LARGE_NICE, LARGE_POOL, LONG_NICE, PAGE_NICE, RUN_NICE, RUN_POOL, VIEW_POOL, lower_priority
from app.serving.session import PAGE_POOL

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="a thread's own priority is Linux's")


def _own_priority() -> int:
    return os.getpriority(os.PRIO_PROCESS, threading.get_native_id())


def _process_priority() -> int:
    return os.getpriority(os.PRIO_PROCESS, os.getpid())  # the main thread's


def test_the_priorities_are_ordered_below_the_loop():
    assert 0 < PAGE_NICE < RUN_NICE < LARGE_NICE < LONG_NICE


@pytest.mark.parametrize(
    ("pool", "nice"),
    [(PAGE_POOL, PAGE_NICE), (VIEW_POOL, PAGE_NICE), (RUN_POOL, RUN_NICE), (LARGE_POOL, LARGE_NICE)],
    ids=["page", "view", "run", "large"],
)
def test_each_pools_threads_run_at_its_priority(pool, nice):
    assert pool.submit(_own_priority).result(timeout=30) == min(19, _process_priority() + nice)


def test_a_pool_thread_started_from_a_lowered_thread_takes_the_processs_priority_as_its_base():
    """As when a page being built (on the page thread, niced) submits the page's first run and so starts a run
    thread: the run thread is at the runs' priority, not at the sum of both."""
    with (
        ThreadPoolExecutor(1, initializer=lower_priority(PAGE_NICE)) as page,
        ThreadPoolExecutor(1, initializer=lower_priority(RUN_NICE)) as runs,
    ):
        started_from_the_page = page.submit(lambda: runs.submit(_own_priority).result(timeout=30)).result(timeout=30)
    assert started_from_the_page == min(19, _process_priority() + RUN_NICE)
