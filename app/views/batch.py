"""Plots that gain glyphs on a live page, with one walk of the page's models.

Bokeh keeps the set of a document's models current by walking every model of the page again after each property set
that refers to models (a new glyph renderer, a legend's items, a range's renderers). A view that adds several glyphs at
once asks for that walk once, at the end (:meth:`bokeh.document.models.DocumentModelManager.freeze`); a view that only
changes values does not freeze at all, since leaving a freeze walks the page even when nothing was added.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

__all__ = ["one_walk"]


@contextlib.contextmanager
def one_walk(model, adding: bool) -> Iterator[None]:
    """While ``adding`` models to ``model``'s document: one walk of its models when the block ends (module docstring).
    Nothing to do when nothing is added or ``model`` is in no document. The freeze ends even if the block raises
    (Bokeh's own context manager would leave the document frozen)."""
    doc = model.document
    if not adding or doc is None:
        yield
        return
    frozen = doc.models.freeze()
    frozen.__enter__()
    try:
        yield
    finally:
        frozen.__exit__(None, None, None)
