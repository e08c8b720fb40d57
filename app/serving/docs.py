"""The documentation at ``/docs/``, served by the dashboard's own server, so a classroom without internet has it.

:func:`install` adds two routes to the Tornado application of a served dashboard (``app.serving.serve`` calls it
from Panel's ``customize_server`` hook, after :func:`app.serving.webguard.install`, so the host check, the headers
and compression apply to these pages too):

* ``/docs/…``: the built HTML pages (``./scripts/docs`` builds them) of :func:`docs_dir` — ``ISL_DOCS_DIR`` or, by
  default, ``docs/_build/html`` of the repository; a directory's ``index.html`` answers for it. While the pages are
  not built, every ``/docs/…`` answers 404 with a short page saying how to build them, never a traceback.
* ``/docs``: a redirect to ``docs/``, relative, so it stays under a reverse proxy's prefix.

See :ref:`serving-docs`.
"""

from __future__ import annotations

import html
import os
import re
from pathlib import Path
from typing import Any

from tornado.routing import PathMatches, Rule
from tornado.web import Application, RequestHandler, StaticFileHandler

__all__ = ["DOCS_ENV", "DOCS_PATH", "docs_dir", "install", "not_built_page"]

DOCS_ENV = "ISL_DOCS_DIR"
DOCS_PATH = "/docs"
REPO = Path(__file__).resolve().parents[2]


def docs_dir() -> Path:
    """The directory of the built pages: ``ISL_DOCS_DIR`` if set (and not empty), else ``docs/_build/html``."""
    configured = os.environ.get(DOCS_ENV, "").strip()
    return Path(configured).expanduser() if configured else REPO / "docs" / "_build" / "html"


def not_built_page(root: Path) -> str:
    """The short HTML page ``/docs/`` answers while ``root`` holds no built documentation."""
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>isl: documentation not built'
        "</title></head><body><main><h1>The documentation is not built</h1>"
        f"<p>This server serves the documentation from <code>{html.escape(str(root))}</code>, which holds no "
        "built pages yet.</p><p>Build them in the repository with <code>./scripts/docs</code> (or set "
        f"<code>{DOCS_ENV}</code> to a directory of built pages) and reload this page; no restart is needed."
        '</p><p><a href="../">Back to the dashboard</a></p></main></body></html>\n'
    )


class _Docs(StaticFileHandler):
    """Tornado's static files (it refuses paths outside the root), with the not-built page for a missing build."""

    def initialize(self, path: str, default_filename: str | None = None, *args: Any, **kwargs: Any) -> None:
        super().initialize(path, default_filename, *args, **kwargs)  # and Tornado's further options, if any
        self._built = (Path(path) / "index.html").is_file()

    async def get(self, path: str, include_body: bool = True) -> None:
        if not self._built:
            self.set_status(404)
            self.set_header("Content-Type", "text/html; charset=utf-8")
            self.set_header("Cache-Control", "no-store")
            self.finish(not_built_page(Path(self.root)))
            return
        await super().get(path, include_body)

    def write_error(self, status_code: int, **kwargs) -> None:
        """A missing page says so in one line (Tornado's own page is as short, this one names the docs)."""
        self.set_header("Content-Type", "text/plain; charset=utf-8")
        self.finish(f"{status_code}: no such page of the documentation\n")


class _ToSlash(RequestHandler):
    def get(self) -> None:
        self.redirect("docs/", permanent=False)  # relative: the browser keeps a proxy's prefix


def install(application: Application, root: Path | None = None) -> Path:
    """Serve the built pages of ``root`` (default :func:`docs_dir`) at ``/docs/`` on ``application``; the root.

    Whether the pages are built is looked up per request, so ``./scripts/docs`` run while the server is up takes
    effect at the next reload."""
    root = Path(root) if root is not None else docs_dir()
    application.wildcard_router.rules[0:0] = [
        Rule(PathMatches(re.escape(DOCS_PATH) + "$"), _ToSlash),
        Rule(
            PathMatches(re.escape(DOCS_PATH) + "/(.*)$"), _Docs, {"path": str(root), "default_filename": "index.html"}
        ),
    ]
    return root
