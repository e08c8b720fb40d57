"""The server's threads take the cores in a stated order: the event loop first, then the page builds, the runs, the
large runs and the long jobs (``app.jobs.base``: each pool's threads lower their own priority as they start)."""

from __future__ import annotations

import os
import sys
import threading

import pytest

from app.jobs import LARGE_NICE, LARGE_POOL, LONG_NICE, PAGE_NICE, RUN_NICE, RUN_POOL, VIEW_POOL
from app.serving.session import PAGE_POOL

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="a thread's own priority is Linux's")


def _own_priority() -> int:
    return os.getpriority(os.PRIO_PROCESS, threading.get_native_id())


def test_the_priorities_are_ordered_below_the_loop():
    assert 0 < PAGE_NICE < RUN_NICE < LARGE_NICE < LONG_NICE


@pytest.mark.parametrize(
    ("pool", "nice"),
    [(PAGE_POOL, PAGE_NICE), (VIEW_POOL, PAGE_NICE), (RUN_POOL, RUN_NICE), (LARGE_POOL, LARGE_NICE)],
    ids=["page", "view", "run", "large"],
)
def test_each_pools_threads_run_at_its_priority(pool, nice):
    process = os.getpriority(os.PRIO_PROCESS, 0)
    assert pool.submit(_own_priority).result(timeout=30) == min(19, process + nice)
    assert _own_priority() == process  # the calling thread (the loop's, in a server) keeps its own
