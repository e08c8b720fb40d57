"""The documentation's mathematics as a reader sees it: every equation typeset by MathJax from the pages' own files,
none wider than the text column at 1280 px, and the typeset pages within WCAG 2.1 AA (axe-core).

The pages are those ``./scripts/docs`` built (``./scripts/test`` builds them first), served by a plain HTTP server on
localhost: what is checked is what chromium computed — MathJax's output elements and their boxes — not the HTML
Sphinx wrote.
"""

from __future__ import annotations

import functools
import http.server
import threading
from pathlib import Path
from urllib.parse import urlsplit

import pytest
from _browser import ROOT, browser
from test_browser_a11y import violations

BUILT = ROOT / "docs" / "_build" / "html"
PAGES = sorted(page.stem for page in BUILT.glob("*.html") if 'class="math notranslate' in page.read_text("utf-8"))
VIEWPORT = {"width": 1280, "height": 800}

#: after MathJax's first typesetting: every display and inline equation, what MathJax made of it, and the boxes
TYPESET = """async () => {
  await MathJax.startup.promise;
  const article = document.querySelector('article.bd-article'), style = getComputedStyle(article);
  const rect = article.getBoundingClientRect();  // the text column: the article's box inside its padding
  const column = {left: rect.left + parseFloat(style.paddingLeft), right: rect.right - parseFloat(style.paddingRight)};
  const box = (out) => {  // what MathJax drew: the union of the boxes of the typeset math and its tags
    const rects = [...out.querySelectorAll('mjx-math, mjx-math *')].map(e => e.getBoundingClientRect())
      .filter(r => r.width > 0);
    return [Math.min(...rects.map(r => r.left)), Math.max(...rects.map(r => r.right))];
  };
  return {
    column: [column.left, column.right],
    display: [...document.querySelectorAll('div.math')].map(div => {
      const out = div.querySelector('mjx-container[display="true"]');
      return {label: div.textContent.slice(0, 60), typeset: out !== null, box: out ? box(out) : null,
              overflow: out ? out.scrollWidth - out.clientWidth : null,
              errors: div.querySelectorAll('mjx-merror').length};
    }),
    inline: [...document.querySelectorAll('span.math')].map(span => span.querySelector('mjx-container') !== null),
    text: document.querySelector('article.bd-article').innerText,
    preformatted: document.querySelectorAll('article.bd-article div.highlight-text').length,
  };
}"""


def _serve(directory: Path):
    handler = functools.partial(_Quiet, directory=str(directory))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args) -> None:  # the test's output is its assertions
        pass


@pytest.fixture(scope="module")
def docs_page():
    """A function opening a built page at 1280 px in one chromium; it returns the page and every host it asked."""
    if not (BUILT / "index.html").is_file():
        pytest.fail(f"the documentation is not built in {BUILT}: run ./scripts/docs (./scripts/test builds it)")
    server = _serve(BUILT)
    try:
        context = browser().new_context(viewport=VIEWPORT)
        try:

            def open_page(name: str):
                page = context.new_page()
                hosts: set[str] = set()
                errors: list[str] = []
                page.on("request", lambda request: hosts.add(urlsplit(request.url).netloc))
                page.on("pageerror", lambda error: errors.append(str(error)))
                page.goto(f"http://127.0.0.1:{server.server_port}/{name}.html")
                return page, hosts, errors

            yield open_page
        finally:
            context.close()
    finally:
        server.shutdown()
        server.server_close()


def test_the_mathematics_pages_have_equations():
    """The pages the checks below walk: at least the model and theory pages (none on a build without mathematics)."""
    assert (BUILT / "index.html").is_file(), f"the documentation is not built in {BUILT}: run ./scripts/docs"
    assert {"model", "theory", "filters", "simulation"} <= set(PAGES), f"pages with typeset mathematics: {PAGES}"


@pytest.mark.parametrize("name", PAGES)
def test_every_equation_is_typeset_from_the_pages_own_files_and_fits_the_column(docs_page, name):
    page, hosts, errors = docs_page(name)
    here = urlsplit(page.url).netloc
    try:
        found = page.evaluate(TYPESET)
        wcag = violations(page)  # axe-core, WCAG 2.1 AA, on the typeset page
    finally:
        page.close()
    assert found["display"], f"{name}: no displayed equation"
    assert [d["label"] for d in found["display"] if not d["typeset"] or d["errors"]] == [], "not typeset, or TeX errors"
    assert all(found["inline"]), f"{name}: {found['inline'].count(False)} inline equations not typeset"
    for raw in ("$$", "\\(", "\\[", "\\begin{", "\\frac"):
        assert raw not in found["text"], f"{name}: raw TeX {raw!r} left in the page's text"
    assert found["preformatted"] == 0, f"{name}: an equation left as preformatted text"
    assert hosts == {here}, f"{name}: requests to other hosts: {hosts}"
    assert errors == []
    assert wcag == [], f"{name}: WCAG 2.1 AA violations"
    left, right = found["column"]
    wide = [
        (d["label"], d["box"], d["overflow"])
        for d in found["display"]
        if d["box"][0] < left - 0.5 or d["box"][1] > right + 0.5 or d["overflow"] > 0
    ]
    assert wide == [], f"{name}: equations wider than the column [{left:.0f}, {right:.0f}] px (box, overflow)"
