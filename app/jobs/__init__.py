"""Jobs: a session's runs on thread pools (:mod:`.threads`), the server's queue of long jobs in child processes
(:mod:`.long`), and what both share (:mod:`.base`: an outcome, CPU priorities, :class:`Cancelled`, :class:`QueueFull`).

The three modules import in one direction only (``threads`` and ``long`` use ``base``), so the package has no
import circle; :class:`Cancelled` is the core's (:class:`isl_core.jobs.Cancelled`), the one way a job ends early
on request, in the core's tasks and in the dashboard's jobs alike.
"""

from __future__ import annotations

from .base import (
    LARGE_NICE,
    LONG_NICE,
    PAGE_NICE,
    RUN_NICE,
    Cancelled,
    Outcome,
    QueueFull,
    call,
    in_steps,
    lower_priority,
)
from .long import LongJobQueue, LongTask, Ticket, in_process, ping
from .threads import LARGE_POOL, RUN_POOL, VIEW_POOL, Jobs, Superseded

__all__ = [
    "LARGE_NICE",
    "LARGE_POOL",
    "LONG_NICE",
    "PAGE_NICE",
    "RUN_NICE",
    "RUN_POOL",
    "VIEW_POOL",
    "Cancelled",
    "Jobs",
    "LongJobQueue",
    "LongTask",
    "Outcome",
    "QueueFull",
    "Superseded",
    "Ticket",
    "call",
    "in_process",
    "in_steps",
    "lower_priority",
    "ping",
]
