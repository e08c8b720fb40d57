"""A stand-in for a session's event loop in headless tests of the threaded app state."""

from __future__ import annotations

import queue


class ManualLoop:
    """Worker threads ``schedule`` outcomes; the test thread applies them with ``pump`` until a condition holds."""

    def __init__(self):
        self.q = queue.Queue()

    def schedule(self, fn):
        self.q.put(fn)

    def pump(self, until, timeout=60.0):
        """Apply scheduled outcomes until ``until()`` is true; ``queue.Empty`` after ``timeout`` s of none."""
        while not until():
            self.q.get(timeout=timeout)()
