"""Less Python per slider change: Panel recomputes a component's design stylesheets on every change of any of its
parameters, and uses them only when the change is to ``stylesheets`` itself.

Panel 1.9's ``Reactive._update_properties`` starts with ``self._design.params(self, doc)``, which resolves the design's
modifiers and builds bokeh stylesheet models, then merges those stylesheets into the change only if the change
includes ``stylesheets``. Every browser event (a slider's ``value``) and every outcome applied to a pane runs it: in a
profile of 22 σ changes in the served page, it was 44 of the events' calls and a quarter of their time on Panel's
thread, and again on the event loop for each updated pane. :func:`skip_unused_design_params` computes them only when
``stylesheets`` changes; the properties sent are the same (a test compares both methods' results).

:func:`install` is idempotent; :mod:`app.page` calls it when the dashboard is imported.
"""
from __future__ import annotations

from typing import Any

__all__ = ["install", "skip_unused_design_params"]


def skip_unused_design_params() -> None:
    """Replace ``Reactive._update_properties`` by one that asks the design only when ``stylesheets`` changes."""
    from panel.reactive import Reactive

    original = Reactive._update_properties
    if getattr(original, "_isl_fast", False):
        return

    def update_properties(self, *events, doc) -> dict[str, Any]:
        if self._design and any(event.name == "stylesheets" for event in events):
            return original(self, *events, doc=doc)
        return self._process_param_change({event.name: event.new for event in events})

    update_properties._isl_fast = True
    update_properties._isl_original = original
    Reactive._update_properties = update_properties


def install() -> None:
    skip_unused_design_params()
