"""Sphinx configuration of the isl docs: ``python -m sphinx -W -b html docs docs/_build/html`` (``./scripts/docs``).

Sphinx, because the numerical Python projects this one builds on document themselves with it (NumPy, SciPy,
python-control): autodoc reads the numpydoc docstrings of :mod:`isl_core`, doctest runs their examples, and MyST lets
the narrative pages be Markdown, as the README is, with LaTeX mathematics (MyST's ``dollarmath`` and ``amsmath``)
typeset by MathJax, as SciPy's and python-control's pages are. The pages need no internet: the theme's files and
MathJax are served with the pages (MathJax from its npm package, pinned by ``docs/js/package-lock.json`` and
installed by ``./scripts/docs``; ``copy_mathjax`` below puts it into the build's ``_static``), so a classroom without
internet reads them at the dashboard's ``/docs``.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def _isl_version() -> str:
    """The package's own ``isl_core.__version__`` where it has one, else the installed distribution's version."""
    import isl_core

    found = getattr(isl_core, "__version__", None)
    if found:
        return str(found)
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("isl")
    except PackageNotFoundError:  # a checkout not installed: pyproject.toml says it
        import tomllib

        return str(tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"])


__version__ = _isl_version()

project = "isl"
author = "the isl authors"
copyright = "2025–2026, the isl authors"
version = release = __version__

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.doctest",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "images/README.md", "js"]
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath", "amsmath"]
nitpicky = True  # a reference to nothing (a renamed module, a function that moved) fails the -W build
#: names of their own modules that the docstrings of isl_core.held_out and isl_core.csv_columns cite, not in the API
nitpick_ignore = [
    ("py:func", "report_columns"),
    ("py:data", "REPORT_FACTOR"),
    ("py:data", "BEYOND"),
    ("py:data", "MAX_BYTES"),
]
numpydoc_show_class_members = False
numpydoc_validation_checks: set[str] = set()
autodoc_member_order = "bysource"
autodoc_typehints = "none"
suppress_warnings: list[str] = []

html_theme = "pydata_sphinx_theme"
html_title = f"isl {version}"
html_static_path = ["_static"]
html_theme_options = {
    "navigation_with_keys": False,
    "show_prev_next": True,
    "icon_links": [],
    "secondary_sidebar_items": ["page-toc"],
    # the search as an icon button named "Search": the theme's default search field shows "Search Ctrl+K" under the
    # name "Search", which WCAG 2.1's "label in name" (2.5.3) refuses
    "navbar_persistent": ["search-button"],
    "footer_start": ["copyright"],
    "footer_end": [],
}
html_show_sourcelink = False
html_copy_source = False

# MathJax 3 from docs/js/node_modules (npm ci --prefix docs/js), copied into the build: the pages load nothing from
# another site. Only the CommonHTML output and what it loads on demand (fonts, TeX extensions, the menu and its
# accessibility tools) are copied: ≈ 9 MB instead of the package's 24.
MATHJAX = ROOT / "docs" / "js" / "node_modules" / "mathjax" / "es5"
MATHJAX_PARTS = ("tex-chtml.js", "input", "output/chtml", "ui", "a11y", "sre", "adaptors")
mathjax_path = "mathjax/tex-chtml.js"  # relative: under the build's _static


def copy_mathjax(app, exception) -> None:
    """Copy ``MATHJAX_PARTS`` of the npm package into ``_static/mathjax`` of an HTML build that succeeded."""
    if exception is not None or app.builder.format != "html":
        return
    target = Path(app.outdir) / "_static" / "mathjax"
    for part in MATHJAX_PARTS:
        source = MATHJAX / part
        if source.is_dir():
            shutil.copytree(source, target / part, dirs_exist_ok=True)
        else:
            (target / part).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target / part)


def setup(app) -> None:
    if not (MATHJAX / "tex-chtml.js").is_file():
        from sphinx.errors import ConfigError

        raise ConfigError(
            f"MathJax is not installed in {MATHJAX.parent}: run `npm ci --prefix docs/js` (./scripts/docs does), "
            "so that the pages typeset their equations without another site"
        )
    app.connect("build-finished", copy_mathjax)
