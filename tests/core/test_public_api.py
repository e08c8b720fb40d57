"""The core's public API is complete and its names have one meaning: every name of the core that the dashboard and
the command line import is exported by ``isl_core`` itself, and the table of bounds is the one the core checks."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import pytest

import isl_core
from isl_core import BOUNDS, M_MAX, SIGMA_RANGE, Execution, Model, Sampling

pytestmark = pytest.mark.core

ROOT = Path(__file__).resolve().parents[2]


def _core_imports() -> list[tuple[str, str, str]]:
    """``(file, module, name)`` of every ``from isl_core.x import y`` in app/ and of every import of the core's
    modules in isl_core/cli (absolute or relative), inside functions too."""
    found = []
    files = [*sorted((ROOT / "app").rglob("*.py")), *sorted((ROOT / "isl_core" / "cli").rglob("*.py"))]
    for path in files:
        in_cli = "cli" in path.relative_to(ROOT).parts[:2]
        for node in ast.walk(ast.parse(path.read_text("utf-8"))):
            if not isinstance(node, ast.ImportFrom):
                continue
            module = node.module or ""
            if node.level and not in_cli:
                continue  # app/ within itself
            if node.level:  # relative, in isl_core/cli: ``from ..sweep import x`` is isl_core.sweep
                module = ".".join(["isl_core", "cli"][: 2 - (node.level - 1)] + ([module] if module else []))
            if not module.startswith("isl_core") or module.startswith("isl_core.cli"):
                continue  # the command line's own modules are its API (the dashboard extends it through them)
            found += [(str(path.relative_to(ROOT)), module, a.name) for a in node.names]
    return found


def test_the_scan_sees_the_imports_it_judges():
    """The scan reads absolute imports of app/ and relative ones of the command line (it would pass on nothing)."""
    seen = {(module, name) for _, module, name in _core_imports()}
    assert ("isl_core.scenario.tuning", "tune") in seen  # relative, from isl_core/cli/scenario.py
    assert any(file.startswith("app/") for file, _, _ in _core_imports())


def test_every_core_name_the_dashboard_and_the_cli_import_is_exported_by_isl_core():
    exported = {id(getattr(isl_core, n)) for n in isl_core.__all__}
    missing = set()
    for file, module, name in _core_imports():
        if module == "isl_core" or name == "__version__":
            assert name in isl_core.__all__, f"{file}: {name} is imported from isl_core but not in __all__"
            continue
        obj = getattr(__import__(module, fromlist=[name]), name, None)
        if obj is None or id(obj) not in exported:
            missing.add(f"{module}.{name} ({file})")
    assert sorted(missing) == []


def test_the_bounds_table_is_what_the_core_checks():
    """Each dashboard range lies in its domain, and the model refuses a value just outside the domain by name."""
    assert BOUNDS.m.range == (1, M_MAX) and BOUNDS.m.hi == M_MAX
    for name in BOUNDS.names():
        b = BOUNDS[name]
        assert b.contains(*b.range), name
    with pytest.raises(ValueError, match=r"^sigma must be a finite number > 0, got 0\.0$"):
        Model(0.5, 3.0, 0.0)
    with pytest.raises(ValueError, match=r"^m must be an integer >= 1 and <= 6, got 7$"):
        Model(0.5, 3.0, 20.0, m=M_MAX + 1)
    with pytest.raises(KeyError, match="the table holds alpha"):
        BOUNDS["gamma"]


def test_sigma_range_means_the_plausible_range_only():
    """``SIGMA_RANGE`` is the plausible σ range of the filters; the IMM's grid has a name of its own."""
    from isl_core.filters import imm

    assert SIGMA_RANGE == (2.0, 200.0)
    assert not hasattr(imm, "SIGMA_RANGE")
    assert imm.IMM_GRID_RANGE[0] < SIGMA_RANGE[0] and imm.IMM_GRID_RANGE[1] > SIGMA_RANGE[1]


def test_requests_are_checked_values():
    s = Sampling.first(3, horizon=20.0, batches=2)
    assert (s.seeds, s.n_seeds, s.horizon, s.batches) == ((0, 1, 2), 3, 20.0, 2)
    with pytest.raises(ValueError, match=r"^seeds must be"):
        Sampling(seeds=(-1,))
    with pytest.raises(ValueError, match=r"^horizon must be a finite number > 0"):
        Sampling(horizon=math.nan)
    with pytest.raises(ValueError, match=r"^batches must be an integer >= 2"):
        Sampling(seeds=(4,), batches=1)
    with pytest.raises(ValueError, match=r"^progress must be a callable"):
        Execution(progress=3)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^sampling must be an isl_core.Sampling"):
        isl_core.sweep([1.0], [20.0], [1.0], sampling={"horizon": 20.0})  # type: ignore[arg-type]
    assert Execution(workers=2).n_workers == 2
