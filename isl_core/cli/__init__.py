"""The ``isl`` command line of the core (``python -m isl_core``): run, sweep, recommend, worstcase and scenario.

* :mod:`~isl_core.cli.parser` — the arguments, the exit codes and :func:`main`, with the :class:`Extension` through
  which the dashboard's ``isl`` console script (:mod:`app.cli`) adds its own commands;
* :mod:`~isl_core.cli.commands` — what run, sweep, recommend and worstcase compute and print;
* :mod:`~isl_core.cli.scenario` — ``isl scenario``: the fair table, the tuning curves and the who-wins maps.
"""

from __future__ import annotations

from .commands import UsageError
from .parser import Extension, build_parser, main, positive, seed_number

__all__ = ["Extension", "UsageError", "build_parser", "main", "positive", "seed_number"]
