"""``python -m app.serving``: serve the dashboard (see :mod:`app.serving.serve`)."""

import sys

from app.serving.serve import main

sys.exit(main())
