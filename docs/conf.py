"""Sphinx configuration of the isl docs: ``python -m sphinx -W -b html docs docs/_build/html`` (``./scripts/docs``).

Sphinx, because the numerical Python projects this one builds on document themselves with it (NumPy, SciPy,
python-control): autodoc reads the numpydoc docstrings of :mod:`isl_core`, doctest runs their examples, and MyST lets
the narrative pages be Markdown, as the README is. The pages need no internet: the theme's files are served with the
pages, and equations are text (no math renderer fetched from a CDN), so a classroom without internet reads them at
the dashboard's ``/docs``.
"""

from __future__ import annotations

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

extensions = ["myst_parser", "numpydoc", "sphinx.ext.autodoc", "sphinx.ext.doctest", "sphinx.ext.viewcode"]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "images/README.md"]
myst_heading_anchors = 3
nitpicky = True  # a reference to nothing (a renamed module, a function that moved) fails the -W build
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
    "footer_start": ["copyright"],
    "footer_end": [],
}
html_show_sourcelink = False
html_copy_source = False
