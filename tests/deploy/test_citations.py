"""The repository cites only what it contains: the code, the tests and the pages cite the docs (``:ref:`` to a label,
Sphinx cross-references to ``docs/``) and the papers by their equation numbers, never a document a newcomer cannot
open."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
#: the internal brief the code once cited by section ("SPEC §4"): not in the repository
OUTSIDE = re.compile(r"\bSPEC\b")
TEXT_SUFFIXES = {".py", ".md", ".sh", ".toml", ".txt", ".yaml", ".yml", ".cfg", ""}
SKIP = {".git", ".venv", "node_modules", "_build", "__pycache__", ".hypothesis", "isl.egg-info"}


def _texts(root: Path) -> list[Path]:
    return [
        p
        for p in sorted(root.rglob("*"))
        if p.is_file() and p.suffix in TEXT_SUFFIXES and not SKIP.intersection(p.relative_to(root).parts)
    ]


def outside_citations(root: Path) -> list[str]:
    return [
        f"{p.relative_to(root)}:{n}"
        for p in _texts(root)
        for n, line in enumerate(p.read_text(encoding="utf-8", errors="replace").splitlines(), 1)
        if OUTSIDE.search(line) and p.resolve() != Path(__file__).resolve()
    ]


def test_the_check_finds_an_outside_citation(tmp_path):
    (tmp_path / "app").mkdir()
    (tmp_path / "app" / "m.py").write_text('"""Step size by the rule of SPEC §4."""\n')
    (tmp_path / "README.md").write_text("The step-size rule (:ref:`step-size`).\n")
    assert outside_citations(tmp_path) == [str(Path("app/m.py")) + ":1"]


def test_no_citation_of_a_document_outside_the_repository():
    assert len(_texts(REPO)) > 100  # the repository was read
    assert outside_citations(REPO) == []
