"""``python -m isl_core``: the core's ``isl`` command line (run, sweep, recommend, worstcase)."""

import sys

from isl_core.cli import main

sys.exit(main())
