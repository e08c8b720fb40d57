"""``python -m isl_core``: the ``isl`` command (the dashboard's commands too where its ``app`` extra is installed)."""

import sys

from isl_core.cli import console

sys.exit(console())
