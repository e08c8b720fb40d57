"""The ``isl`` command line of the core (``python -m isl_core``): run, sweep, recommend, worstcase and scenario.

* :mod:`~isl_core.cli.parser` — the arguments, the exit codes, :func:`main` and the ``isl`` console script
  :func:`console`, which adds the dashboard's commands (:mod:`app.cli`, an :class:`Extension`) where its ``app``
  extra is installed;
* :mod:`~isl_core.cli.commands` — what run, sweep, recommend and worstcase compute and print;
* :mod:`~isl_core.cli.scenario` — ``isl scenario``: the fair table, the tuning curves and the who-wins maps.
"""

from __future__ import annotations

from .commands import UsageError
from .parser import APP_COMMANDS, Extension, build_parser, console, installed_extension, main, positive, seed_number

__all__ = [
    "APP_COMMANDS",
    "Extension",
    "UsageError",
    "build_parser",
    "console",
    "installed_extension",
    "main",
    "positive",
    "seed_number",
]
