"""Docstrings and comments explain what the code does and why; measurements and history live on the documentation's
performance page and in the changelog (:ref:`development-docs`). This scans every docstring and comment of the
packages for the marks of a lab notebook: timings, before → after figures, percentiles, dates, commit hashes, counts of
lost events and talk of earlier runs."""

from __future__ import annotations

import ast
import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("isl_core", "app")

#: what narration looks like, by name; each pattern is tried on one docstring or one comment at a time
NARRATION = {
    "a timing": re.compile(r"\d[\d.,]*\s?(?:ns|µs|us|ms)\b|(?:≈\s?\d[\d.]*|\d[\d.]*\s?[–-]\s?\d[\d.]*)\s?s\b"),
    "a before → after figure": re.compile(r"\d[\d.,]*\s?(?:[a-zµ%]{1,3}\s?)?→\s?[\d.]+"),
    "a percentile": re.compile(r"\bp(?:50|90|95|99)\b"),
    "a date": re.compile(r"\b20\d\d-\d\d-\d\d\b"),
    "a commit": re.compile(r"\b(?=[0-9a-f]*\d)(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}\b"),
    "a count of lost events": re.compile(r"\blost \d|\b\d+ (?:in|of) \d{1,3}(?:[ ,]\d{3})+\b"),
    "an earlier run": re.compile(
        r"\b(?:in an? (?:earlier|previous|first) run|earlier (?:run|grid|table|version|revision)s?\b|used to\b"
        r"|before (?:this|the) (?:change|fix|patch)|measured:)",
        re.IGNORECASE,
    ),
}


def texts(source: str) -> list[tuple[int, str]]:
    """Every docstring (module, class, function) and every comment of ``source``, with its first line's number."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            doc = ast.get_docstring(node, clean=False)
            if doc is not None:
                found.append((node.body[0].lineno, doc))
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            found.append((tok.start[0], tok.string))
    return found


def narration(source: str) -> list[tuple[int, str, str]]:
    """(line, kind, the text matched) of every mark of :data:`NARRATION` in the docstrings and comments of
    ``source``; code and string values are not read."""
    hits = []
    for line, text in texts(source):
        for kind, pattern in NARRATION.items():
            hits += [(line + text[: m.start()].count("\n"), kind, m.group()) for m in pattern.finditer(text)]
    return sorted(hits)


@pytest.mark.parametrize(
    "text",
    [
        '"""Redrawn p50 79.4 → 72.8 ms."""',
        "# in an earlier run, Bailey's polar method cost 29 ns",
        '"""The same steps lost 1 registration in 20 000."""',
        "x = 1  # measured at 1e59c63",
        '"""Measured on 2026-12-05."""',
        "# a tab stayed blank for 2–3 s",
        "def f():\n    '''Data arrived 83-90 → 44 when both sides send.'''",
    ],
)
def test_the_scan_finds_narration(text):
    assert narration(text)


@pytest.mark.parametrize(
    "text",
    [
        '"""Innovations clipped at ± c·σ̂; the tube is X̂ ± 3 s_i (A.30)."""',
        'LABEL = "σ 200 → 2 at 10/r_min"',
        '"""The fit was cancelled: raised as InterruptedError."""',
        "# ties keep the earlier sample, as argmin does",
    ],
)
def test_the_scan_leaves_explanations_alone(text):
    assert narration(text) == []


@pytest.mark.parametrize("package", PACKAGES)
def test_no_docstring_or_comment_narrates_measurements_or_history(package):
    found = [
        f"{path.relative_to(ROOT)}:{line}: {kind}: {match!r}"
        for path in sorted((ROOT / package).rglob("*.py"))
        for line, kind, match in narration(path.read_text(encoding="utf-8"))
    ]
    assert not found, "measurements and history go to docs/performance.md and docs/changelog.md:\n" + "\n".join(found)
