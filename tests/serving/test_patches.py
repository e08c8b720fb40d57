"""The patches of Panel, Bokeh and BokehJS (app.serving.patches): each target still what its patch was written
against, installed by the server's start-up and never by a view, each listed on the development page with its
drafted upstream report."""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
from importlib.metadata import version
from pathlib import Path

import pytest

from app.serving.patches import PATCHES, digest

ROOT = Path(__file__).resolve().parents[2]
TARGETS = [(patch, target, recorded) for patch in PATCHES for target, recorded in patch.targets.items()]


@pytest.mark.parametrize(
    "patch, target, recorded", TARGETS, ids=[f"{p.name.split()[0]}:{t.rsplit(':', 1)[-1]}" for p, t, _ in TARGETS]
)
def test_each_patched_target_is_the_code_its_patch_was_written_for(patch, target, recorded):
    now = digest(target)
    assert now is not None, (
        f"{target} is gone from the installed {patch.library}: the patch {patch.name} (written for "
        f"{patch.written_for}) no longer applies; see docs/development.md, 'Patches of Panel and Bokeh'"
    )
    assert now == recorded, (
        f"{target} changed since {patch.library} {patch.written_for} (digest {recorded}, now {now}): re-read the "
        f"patch {patch.name} against it (is it still needed? docs/upstream/{patch.upstream}), then record the new "
        f"digest in app/serving/patches.py"
    )


@pytest.mark.parametrize("library, minor", [("panel", "1.9"), ("bokeh", "3.9")])
def test_the_installed_libraries_are_the_minor_versions_the_patches_were_written_for(library, minor):
    """pyproject.toml bounds them to these; a newer minor version is taken in once every patch is checked."""
    assert version(library).startswith(f"{minor}."), f"{library} {version(library)}: the patches are for {minor}"
    written = [
        (patch.name, release)
        for patch in PATCHES
        for name, release in zip(patch.library.split(", "), patch.written_for.split(", "), strict=True)
        if name.removesuffix("js") == library
    ]
    assert written and all(release.startswith(f"{minor}.") for _, release in written), written


def test_a_changed_or_missing_target_changes_its_digest(tmp_path, monkeypatch):
    """The guard can fail: another body, another digest; a definition gone, none (Python and TypeScript targets)."""
    module = tmp_path / "isl_guard_probe.py"
    monkeypatch.syspath_prepend(str(tmp_path))
    module.write_text("class A:\n    def f(self):\n        return 1\nX: list = []\n")
    before = digest("isl_guard_probe:A.f"), digest("isl_guard_probe:X")
    module.write_text("class A:\n    def f(self):\n        return 2\nY = 1\n")
    assert None not in before and digest("isl_guard_probe:A.f") not in (None, before[0])
    assert digest("isl_guard_probe:X") is None and digest("isl_guard_probe:A.g") is None
    assert digest("bokehjs:core/dom:InlineStyleSheet._no_such_method") is None
    assert digest("bokehjs:core/no_such_module:View.render") is None


def _imported(path: Path) -> set[str]:
    names = set()
    package = "app.views" if path.parent.name == "views" else "app"
    for node in ast.walk(ast.parse(path.read_text("utf-8"))):
        if isinstance(node, ast.ImportFrom):
            base = package.rsplit(".", node.level - 1)[0] if node.level else ""
            module = ".".join(filter(None, [base if node.level else "", node.module or ""]))
            names |= {module, *(f"{module}.{alias.name}" for alias in node.names)}
        elif isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
    return names


def test_no_view_imports_the_modules_that_patch():
    """The page, the app script and the views use app.serving.session; the patching modules are the server's."""
    patching = {f"app.serving.{name}" for name in ("fastpath", "hardening", "offloop")}
    views = [ROOT / "app" / "page.py", ROOT / "app" / "app.py", *sorted((ROOT / "app" / "views").glob("*.py"))]
    offences = {str(p.relative_to(ROOT)): sorted(_imported(p) & patching) for p in views}
    assert {name: found for name, found in offences.items() if found} == {}
    assert "app.serving.session.release_on_destroy" in _imported(ROOT / "app" / "page.py")  # the scan sees imports


def test_importing_the_dashboard_patches_nothing_and_the_start_up_installs_once():
    code = (
        "import json, sys\n"
        "from bokeh.document import Document\n"
        "from panel.reactive import Syncable\n"
        "import panel as pn\n"
        "import app.page, app.views\n"
        "marks = lambda: [hasattr(Syncable._change_event, '_isl_serialized'), "
        "hasattr(Document.apply_json_patch, '_isl_keeps_unsent'), hasattr(type(pn.state).execute, '_isl_original')]\n"
        "imported = marks() + [m for m in ('fastpath', 'hardening', 'offloop') if 'app.serving.' + m in sys.modules]\n"
        "from app.serving import patches\n"
        "patches.install()\n"
        "first = (Syncable._change_event, Document.apply_json_patch)\n"
        "patches.install()\n"
        "print(json.dumps([imported, marks(), first == (Syncable._change_event, Document.apply_json_patch)]))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    imported, installed, same = json.loads(done.stdout.strip().splitlines()[-1])
    assert imported == [False, False, False] and installed == [True, True, True] and same


def test_every_patch_is_on_the_development_page_with_its_upstream_draft():
    page = (ROOT / "docs" / "development.md").read_text("utf-8")
    table = page[page.index("## Patches of Panel and Bokeh") :]
    for patch in PATCHES:
        draft = ROOT / "docs" / "upstream" / patch.upstream
        assert draft.is_file(), f"no drafted report {draft.relative_to(ROOT)} for {patch.name}"
        text = draft.read_text("utf-8")
        assert all(word in text for word in ("Symptom", "Reproduction", "Proposed fix")), draft.name
        assert f"`{patch.name.split()[0]}`" in table and f"upstream/{patch.upstream}" in table, patch.name
    counted = re.search(r"(\d+) patches? .*?(\d+) targets?", table)
    assert counted and (int(counted[1]), int(counted[2])) == (len(PATCHES), len(TARGETS))
