"""The core is importable on its own and pulls in no UI library (STYLE.md, principle 1)."""
from __future__ import annotations

import json
import subprocess
import sys

import isl_core

UI_MODULES = ("panel", "bokeh", "param", "matplotlib")


def test_importing_the_core_loads_no_ui_library():
    code = (
        "import json, sys\n"
        "import isl_core, isl_core.reference\n"
        f"print(json.dumps([m for m in {UI_MODULES!r} if m in sys.modules]))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300)
    assert json.loads(out.stdout.strip().splitlines()[-1]) == []


def test_public_names_exist_and_are_documented():
    assert isl_core.__all__, "isl_core must declare its public API"
    for name in isl_core.__all__:
        obj = getattr(isl_core, name)
        if callable(obj):
            assert obj.__doc__ and obj.__doc__.strip(), f"isl_core.{name} has no docstring"
