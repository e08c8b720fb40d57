"""The core is importable on its own and pulls in no UI library (STYLE.md, principle 1)."""
from __future__ import annotations

import ast
import graphlib
import json
import subprocess
import sys
from pathlib import Path

import pytest

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


ROOT = Path(__file__).resolve().parents[2]
MAX_MODULE_LINES = 400


def _imports(path: Path, package: str) -> set[str]:
    """Modules of ``package`` that ``path`` imports anywhere (top level or inside a function)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text("utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            found |= {node.module.split(".")[0]} if node.module else {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith(f"{package}."):
            found.add(node.module.split(".")[1])
        elif isinstance(node, ast.Import):
            found |= {a.name.split(".")[1] for a in node.names if a.name.startswith(f"{package}.")}
    return found


def test_the_core_has_no_import_cycle():
    graph = {p.stem: _imports(p, "isl_core") - {p.stem} for p in (ROOT / "isl_core").glob("*.py")}
    order = graphlib.TopologicalSorter(graph)
    try:
        order.prepare()
    except graphlib.CycleError as exc:
        pytest.fail(f"import cycle in isl_core: {' -> '.join(exc.args[1])}")


def test_the_dashboard_uses_only_the_cores_public_modules():
    """No private module or name of the core (``isl_core._x``, ``from isl_core.m import _x``), and no second
    computation path: the ν-sweep and the worst case come from the core's ``sweep`` and ``worst_case``."""
    offences = []
    for path in sorted((ROOT / "app").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text("utf-8"))):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("isl_core"):
                names = [node.module, *(a.name for a in node.names)]
                offences += [f"{path.relative_to(ROOT)}: {n}" for n in names
                             if any(part.startswith("_") for part in n.split("."))]
            elif isinstance(node, ast.Name | ast.Attribute) and "simulate_rmse" in (getattr(node, "id", None),
                                                                                    getattr(node, "attr", None)):
                offences.append(f"{path.relative_to(ROOT)}: simulate_rmse")
    assert offences == []


def test_no_module_is_over_400_lines():
    sizes = {str(p.relative_to(ROOT)): len(p.read_text("utf-8").splitlines())
             for folder in ("app", "isl_core", "scripts", "benchmarks") for p in (ROOT / folder).rglob("*.py")}
    assert sizes, "no module found"
    assert {name: n for name, n in sizes.items() if n > MAX_MODULE_LINES} == {}
