"""The core as a package: importable on its own without any UI library (STYLE.md, principle 1), a layout without
import circles, small modules and functions, kinds compared by name, no private name imported across modules, every
equation it uses cited by its number, and the dashboard on its public modules only."""

from __future__ import annotations

import ast
import graphlib
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from _imports import loaded_by

import isl_core

UI_MODULES = ("panel", "bokeh", "param", "matplotlib")


def test_importing_the_core_loads_no_ui_library():
    assert loaded_by("import isl_core, isl_core.reference", UI_MODULES) == []


def test_public_names_exist_and_are_documented():
    assert isl_core.__all__, "isl_core must declare its public API"
    for name in isl_core.__all__:
        obj = getattr(isl_core, name)
        if callable(obj):
            assert obj.__doc__ and obj.__doc__.strip(), f"isl_core.{name} has no docstring"


ROOT = Path(__file__).resolve().parents[2]
CORE = ROOT / "isl_core"
MAX_MODULE_LINES = 400
MAX_FUNCTION_LINES = 80


def _name(path: Path) -> str:
    """The dotted module name of a file of the core (a package's ``__init__.py`` is the package)."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_name(p): p for p in sorted(CORE.rglob("*.py"))}
#: the core and the dashboard: the import-circle and function-size checks cover both
PROJECT = {_name(p): p for package in ("isl_core", "app") for p in sorted((ROOT / package).rglob("*.py"))}


def _target(name: str) -> str:
    """The project's module that importing ``name`` (a module, or a name in one) runs: the longest known prefix."""
    parts = name.split(".")
    while parts and ".".join(parts) not in PROJECT:
        parts.pop()
    return ".".join(parts)


def _imports(module: str) -> set[str]:
    """The project's modules that ``module`` imports anywhere (top level or inside a function): ``from .x import y``
    resolved against its package, ``y`` itself when it is a module."""
    path = PROJECT[module]
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text("utf-8"))):
        if isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            target = ".".join(base + ([node.module] if node.module else []))
            if target.split(".")[0] in ("isl_core", "app"):
                found |= {_target(f"{target}.{alias.name}") for alias in node.names}
        elif isinstance(node, ast.Import):
            found |= {_target(alias.name) for alias in node.names if alias.name.split(".")[0] in ("isl_core", "app")}
    return found - {module, ""}


def test_the_import_graph_sees_relative_and_nested_imports():
    """The graph the cycle test sorts is the real one: a subpackage's relative imports resolve to modules."""
    assert "isl_core.filters.base" in _imports("isl_core.filters.adaptive")
    assert "isl_core.model" in _imports("isl_core.filters.adaptive")
    assert "isl_core.filters.adaptive" in _imports("isl_core.filters")
    assert "app.jobs.base" in _imports("app.jobs.long")  # the dashboard's modules are in the graph too
    assert {"app.state.room", "app.inputs"} <= _imports("app.state.session")


def test_no_import_cycle():
    """No circle among the modules of the core and the dashboard (subpackages included), counting the imports inside
    functions too."""
    order = graphlib.TopologicalSorter({module: _imports(module) for module in PROJECT})
    try:
        order.prepare()
    except graphlib.CycleError as exc:
        pytest.fail(f"import cycle: {' -> '.join(exc.args[1])}")


def test_no_module_imports_a_private_name_of_another():
    """What modules share is public in the module that defines it (the engine's internals live in the private
    module ``isl_core._engine``, whose names need no underscore): ``from .x import _y`` is not written."""
    offences = []
    for module, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text("utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module != "__future__":
                offences += [
                    f"{module}: {a.name}" for a in node.names if a.name.startswith("_") and not a.name.endswith("__")
                ]  # __version__ is public
    assert offences == []


def _njit(node: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    """Whether ``node`` is compiled by numba (``@njit``, ``@numba.njit(...)``, ``@jit``)."""
    return any(re.search(r"\b(njit|jit)\b", ast.unparse(d)) for d in node.decorator_list)


def code_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """A function's length in lines: its signature and body, without its docstring (numpydoc's Parameters, Returns
    and Examples make a public function's docstring long on purpose; the limit is on the code)."""
    lines = node.end_lineno - node.lineno + 1
    first = node.body[0]
    if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
        lines -= first.end_lineno - first.lineno + 1
    return lines


def test_a_function_is_measured_without_its_docstring():
    code = 'def f(a,\n      b):\n    """One.\n\n    Two.\n    """\n    x = a\n    return x + b\n'
    (node,) = ast.parse(code).body
    assert isinstance(node, ast.FunctionDef) and code_lines(node) == 4


def test_no_function_is_over_80_lines_outside_the_numba_kernels():
    long = {}
    for module, path in PROJECT.items():
        for node in ast.walk(ast.parse(path.read_text("utf-8"))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and not _njit(node):
                lines = code_lines(node)
                if lines > MAX_FUNCTION_LINES:
                    long[f"{module}.{node.name}"] = lines
    assert long == {}


def test_the_kernels_compare_filter_kinds_by_name():
    """``kind[f] == KIND_ADAPTIVE``, never ``kind[f] == 2``: a comparison of a kind or a lane with a bare number."""
    bare = []
    for module, path in MODULES.items():
        if not module.startswith("isl_core.kernels"):
            continue
        for node in ast.walk(ast.parse(path.read_text("utf-8"))):
            if isinstance(node, ast.Compare):
                sides = [node.left, *node.comparators]
                about_kind = any(re.search(r"\b(kind|lane)\b", ast.unparse(side)) for side in sides)
                number = any(isinstance(side, ast.Constant) and isinstance(side.value, int) for side in sides)
                if about_kind and number:
                    bare.append(f"{module}:{node.lineno}: {ast.unparse(node)}")
    assert bare == []


def _private(name: str) -> bool:
    """``_x`` is private; ``__version__`` (a dunder) is not."""
    return name.startswith("_") and not name.endswith("__")


def test_the_dashboard_uses_only_the_cores_public_modules():
    """No private module or name of the core (``isl_core._x``, ``from isl_core.m import _x``), and no second
    computation path: the ν-sweep and the worst case come from the core's ``sweep`` and ``worst_case``."""
    offences = []
    for path in sorted((ROOT / "app").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text("utf-8"))):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("isl_core"):
                names = [node.module, *(a.name for a in node.names)]
                private = [n for n in names if any(_private(part) for part in n.split("."))]
                offences += [f"{path.relative_to(ROOT)}: {n}" for n in private]
            elif isinstance(node, ast.Name | ast.Attribute) and "simulate_rmse" in (
                getattr(node, "id", None),
                getattr(node, "attr", None),
            ):
                offences.append(f"{path.relative_to(ROOT)}: simulate_rmse")
    assert offences == []


def test_no_module_is_over_400_lines():
    sizes = {
        str(p.relative_to(ROOT)): len(p.read_text("utf-8").splitlines())
        for folder in ("app", "isl_core", "scripts", "benchmarks")
        for p in (ROOT / folder).rglob("*.py")
    }
    assert sizes, "no module found"
    assert {name: n for name, n in sizes.items() if n > MAX_MODULE_LINES} == {}


def test_no_function_check_is_fooled_by_a_kernel_decorator():
    code = (
        "import numba\nfrom numba import njit\n@njit(cache=True)\ndef f():\n    pass\ndef g():\n    pass\n"
        "@numba.jit\ndef h():\n    pass\n@adjust\ndef k():\n    pass\n"
    )
    flags = [_njit(n) for n in ast.parse(code).body if isinstance(n, ast.FunctionDef)]
    assert flags == [True, False, True, False]


#: equations the core computes, by their number in paper A (A.n) or paper B (B.n)
USED = [
    "A.17",
    "A.21",
    "A.23",
    "A.24",
    "A.29",
    "A.30",
    "A.31",
    "B.4",
    "B.5",
    "B.6",
    "B.7",
    "B.23",
    "B.24",
    "B.25",
    "B.26",
    "B.46",
    "B.54",
]


def _cited(number: str) -> list[str]:
    """Core modules citing equation ``number`` by itself (``B.4`` is not ``B.40``), subpackages included."""
    pattern = re.compile(rf"(?<![\w.]){re.escape(number)}(?![\d])")
    return [module for module, path in MODULES.items() if pattern.search(path.read_text("utf-8"))]


@pytest.mark.parametrize("number", USED)
def test_each_equation_the_core_uses_is_cited_by_its_number(number):
    assert _cited(number), f"no module of isl_core cites ({number})"


def test_a_range_does_not_count_as_citing_its_inner_numbers():
    assert not re.search(r"(?<![\w.])B\.5(?![\d])", "B.4–B.7 and B.54")  # the check above is not fooled


#: a finder that refuses the UI libraries, as if they were not installed (run first in a subprocess)
WITHOUT_UI = f"""
import importlib.abc, sys
class NotInstalled(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {UI_MODULES!r}:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
        return None
sys.meta_path.insert(0, NotInstalled())
"""


def _requirements(extra: str | None) -> set[str]:
    """The names of the distribution's requirements: those of ``extra``, or (None) those without an extra."""
    from importlib.metadata import requires

    names = set()
    for line in requires("isl") or []:
        marker = re.search(r"""extra\s*==\s*["']([^"']+)["']""", line)
        if (marker.group(1) if marker else None) == extra:
            names.add(re.match(r"[A-Za-z0-9_.-]+", line).group().lower())
    return names


def test_the_installed_core_requires_no_ui_library_and_the_app_extra_brings_them():
    """``pip install .`` gives the core with numpy, scipy and numba; ``isl[app]`` adds the dashboard's libraries."""
    assert {"numpy", "scipy", "numba"} <= _requirements(None)
    assert _requirements(None).isdisjoint(UI_MODULES)
    assert set(UI_MODULES) <= _requirements("app")


def test_without_the_ui_libraries_isl_runs_and_serve_says_what_to_install():
    """With panel, bokeh, param and matplotlib refused on import, ``isl run`` runs to the end and ``isl serve``
    names the extra to install and exits 2."""
    code = WITHOUT_UI + (
        "import contextlib, io, json\n"
        "from isl_core.cli import console\n"
        "err = io.StringIO()\n"
        "with contextlib.redirect_stderr(err):\n"
        "    serve = console(['serve'])\n"
        "out = io.StringIO()\n"
        "with contextlib.redirect_stdout(out):\n"
        "    run = console(['run', '--horizon', '20', '--json'])\n"
        f"loaded = [m for m in {UI_MODULES!r} if m in sys.modules]\n"
        "print(json.dumps([serve, err.getvalue(), run, json.loads(out.getvalue()), loaded]))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    serve, message, run, result, loaded = json.loads(done.stdout.strip().splitlines()[-1])
    assert (serve, message.strip()) == (2, "isl serve: the dashboard needs the app extra: pip install 'isl[app]'")
    assert run == 0 and len(result["ratio_hat"]) == result["model"]["m"] and loaded == []
