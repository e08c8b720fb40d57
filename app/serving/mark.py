"""Marks on the functions the dashboard installs in place of a library's own (the patches listed in
:mod:`app.serving.patches`): a second install sees its mark and does nothing, and the original stays reachable."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["mark"]

F = TypeVar("F", bound=Callable[..., Any])


def mark(fn: F, **marks: Any) -> F:
    """``fn`` with ``marks`` set as its attributes (e.g. ``_isl_fast=True, _isl_original=original``), returned.

    Python functions take attributes, but a type checker knows only a function's signature: setting them here
    keeps each patch's own code checked."""
    for name, value in marks.items():
        setattr(fn, name, value)
    return fn
