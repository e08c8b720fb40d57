"""The documentation: every page the code cites exists, and the dashboard's server serves the built pages at /docs/.

Nothing here builds the pages: ``./scripts/test`` builds them (warnings as errors) before pytest starts, and
``./scripts/docs`` does on its own; a test that needs them says how to build them when they are missing.
"""

from __future__ import annotations

import re
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from _serving import fixture_app, served

import isl_core

REPO = Path(__file__).resolve().parents[2]
BUILT = REPO / "docs" / "_build" / "html"
CITING = ("isl_core", "app", "tests", "scripts", "benchmarks")  #: the folders whose Python files cite the pages

_CITED = re.compile(r":ref:`(?:[^`<]*<)?([A-Za-z0-9_.:-]+)>?`")
_DEFINED = re.compile(r"^\(([A-Za-z0-9_.:-]+)\)=\s*$", re.MULTILINE)
_FENCED = re.compile(r"^(```|~~~).*?^\1\s*$", re.MULTILINE | re.DOTALL)  #: code blocks: a label there is an example


def cited_labels(text: str) -> set[str]:
    """The labels ``text`` cites with Sphinx's ref role: the label alone, or words and the label in angle brackets."""
    return set(_CITED.findall(text))


def page_labels(text: str) -> list[str]:
    """The MyST labels ``(label)=`` a page's Markdown defines (outside its code blocks)."""
    return _DEFINED.findall(_FENCED.sub("", text))


def defined_labels() -> dict[str, Path]:
    """Every label the pages define, with its page."""
    return {
        label: page
        for page in sorted((REPO / "docs").glob("*.md"))
        for label in page_labels(page.read_text(encoding="utf-8"))
    }


def citations() -> dict[str, list[str]]:
    """Every label cited in the Python files of :data:`CITING`, with the files citing it."""
    found: dict[str, list[str]] = {}
    for folder in CITING:
        for path in sorted((REPO / folder).rglob("*.py")):
            if "node_modules" in path.parts:
                continue
            for label in cited_labels(path.read_text(encoding="utf-8")):
                found.setdefault(label, []).append(str(path.relative_to(REPO)))
    return found


def get(url: str, host: str | None = None) -> tuple[int, dict[str, str], str]:
    """Status, headers and text of a GET that follows no redirect."""

    class NoRedirect(urllib.request.HTTPRedirectHandler):
        def redirect_request(self, *args, **kwargs):
            return None

    request = urllib.request.Request(url, headers={"Host": host} if host else {})
    try:
        with urllib.request.build_opener(NoRedirect).open(request, timeout=30) as answer:
            return answer.status, dict(answer.headers), answer.read().decode("utf-8")
    except urllib.error.HTTPError as error:
        with error:
            return error.code, dict(error.headers), error.read().decode("utf-8", "replace")


def test_the_citation_pattern_finds_both_spellings_and_nothing_else():
    text = "see :ref:`period-statistic` and :ref:`the rate <r-min>`; not {ref}`model` nor :func:`simulate`"
    assert cited_labels(text) == {"period-statistic", "r-min"}


def test_a_label_in_a_code_block_is_an_example_not_a_definition():
    assert page_labels("(model)=\n\n# The model\n\n```text\n(example)=\n```\n") == ["model"]


def test_every_label_the_code_cites_is_defined_on_a_page():
    defined = defined_labels()
    cited = citations()
    assert "serving-docs" in cited, "the citations were not found (the serving module cites :ref:`serving-docs`)"
    missing = {label: files for label, files in cited.items() if label not in defined}
    assert not missing, (
        "labels cited in the code but defined on no page of docs/ (add `(label)=` before a heading, "
        f"or fix the citation): {missing}"
    )


def test_labels_are_defined_once():
    seen: dict[str, list[str]] = {}
    for page in sorted((REPO / "docs").glob("*.md")):
        for label in page_labels(page.read_text(encoding="utf-8")):
            seen.setdefault(label, []).append(page.name)
    assert {label: pages for label, pages in seen.items() if len(pages) > 1} == {}


def test_the_header_links_to_the_docs_relative_to_the_page():
    from app.views.about import DOCS_LINK, docs_link

    assert 'href="./docs/"' in DOCS_LINK and DOCS_LINK in docs_link().object  # relative: kept under a prefix


def _built() -> Path:
    if not (BUILT / "index.html").is_file():
        pytest.fail(f"the documentation is not built in {BUILT}: run ./scripts/docs (./scripts/test builds it)")
    return BUILT


def test_the_api_reference_documents_every_public_name_through_the_package():
    page = (_built() / "api.html").read_text(encoding="utf-8")
    missing = [name for name in isl_core.__all__ if not name.startswith("__") and f'id="isl_core.{name}"' not in page]
    assert not missing, f"isl_core.__all__ names without an entry in the API reference: {missing}"


def test_the_built_pages_load_nothing_from_another_site():
    """A classroom without internet reads them whole: no script, style, font or image comes from elsewhere."""
    fetched = re.compile(
        r"""<(?:script|img|iframe|source)\b[^>]*\bsrc=["']((?:https?:)?//[^"']+)|"""
        r"""<link\b[^>]*\bhref=["']((?:https?:)?//[^"']+)|url\(["']?((?:https?:)?//[^)"']+)"""
    )
    pages = [*_built().rglob("*.html"), *_built().rglob("*.css")]
    remote = {
        (page.name, next(u for u in match if u))
        for page in pages
        for match in fetched.findall(page.read_text(encoding="utf-8"))
    }
    assert remote == set()
    assert fetched.findall('<script src="https://cdn.example/x.js"></script>')  # the pattern sees a remote script


def test_the_server_serves_the_built_docs(app_server):
    """The shared dashboard server (tests/conftest.py), started without ``ISL_DOCS_DIR``: its pages are those of
    ``docs/_build/html``, the default place."""
    built = _built()
    url = app_server[0].rsplit("/", 1)[0]
    status, headers, text = get(f"{url}/docs/")
    assert status == 200 and headers["Content-Type"].startswith("text/html")
    assert text == (built / "index.html").read_text(encoding="utf-8")
    assert headers["X-Content-Type-Options"] == "nosniff"  # the dashboard's headers cover the pages too
    status, _, text = get(f"{url}/docs/model.html")
    assert status == 200 and text == (built / "model.html").read_text(encoding="utf-8")
    status, headers, _ = get(f"{url}/docs/_static/mathjax/tex-chtml.js")  # the pages' math renderer, as a script
    assert status == 200 and "javascript" in headers["Content-Type"]
    status, headers, _ = get(f"{url}/docs")
    assert status in (301, 302) and headers["Location"] == "docs/"  # relative: a proxy's prefix stays
    assert get(f"{url}/docs/no-such-page.html")[0] == 404
    assert get(f"{url}/docs/../pyproject.toml")[0] in (400, 403, 404)
    assert get(f"{url}/docs/", host="evil.example:80")[0] == 403  # the host check applies


def test_without_a_build_docs_says_how_to_build_it(tmp_path):
    empty = tmp_path / "not-built"
    empty.mkdir()
    with served(tmp_path, "--stats-interval", "0", script=fixture_app(tmp_path), env={"ISL_DOCS_DIR": str(empty)}) as (
        url,
        _,
        log,
    ):
        for path in ("/docs/", "/docs/model.html"):
            status, headers, text = get(url + path)
            assert status == 404 and headers["Content-Type"].startswith("text/html")
            assert "./scripts/docs" in text and "ISL_DOCS_DIR" in text and "Traceback" not in text
        assert get(f"{url}/app")[0] == 200  # the dashboard itself is unaffected
        assert "Traceback" not in log.read_text()
