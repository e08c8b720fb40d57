"""What an import costs a fresh process: :func:`loaded_by` runs the import in a new interpreter and says which of
some modules it brought in (for the tests that keep libraries out of an import: the core without the UI, the page
without what only a computation needs)."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Sequence

__all__ = ["loaded_by"]


def loaded_by(statement: str, modules: Sequence[str]) -> list[str]:
    """Those of ``modules`` in ``sys.modules`` after ``statement`` (an import) ran in a fresh interpreter, in order."""
    code = f"import json, sys\n{statement}\nprint(json.dumps([m for m in {tuple(modules)!r} if m in sys.modules]))\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300)
    return json.loads(out.stdout.strip().splitlines()[-1])
