"""Panel's per-change work without the design's stylesheets (app.serving.fastpath): the same properties are sent."""
from __future__ import annotations

import panel as pn
import param
from bokeh.document import Document
from panel.reactive import Reactive

from app.serving import fastpath


def _changes(widget, **values) -> list[param.parameterized.Event]:
    """The events param gives ``widget``'s watchers for ``values``."""
    seen: list = []
    watcher = widget.param.watch(lambda *events: seen.extend(events), list(values))
    try:
        widget.param.update(**values)
    finally:
        widget.param.unwatch(watcher)
    return seen


def test_the_properties_sent_are_panels_own_and_the_design_is_asked_only_for_stylesheets(monkeypatch):
    fastpath.install()
    fast = Reactive._update_properties
    original = fast._isl_original
    doc = Document()
    slider = pn.widgets.FloatSlider(start=0.0, end=10.0, value=1.0, design=pn.theme.Fast)
    slider.get_root(doc)  # a model in a document, as in a session
    asked: list = []
    design_params = type(slider._design).params
    monkeypatch.setattr(type(slider._design), "params", lambda *a, **k: asked.append(1) or design_params(*a, **k))

    value = _changes(slider, value=2.5)
    asked.clear()  # (the change itself updated the slider's model, through the fast method)
    assert fast(slider, *value, doc=doc) == original(slider, *value, doc=doc) == {"value": 2.5}
    assert len(asked) == 1  # Panel's own method asked; the fast one did not

    sheets = _changes(slider, stylesheets=[":host { color: red; }"])
    asked.clear()
    mine, panels = fast(slider, *sheets, doc=doc), original(slider, *sheets, doc=doc)
    assert len(asked) == 2  # a change of stylesheets goes through Panel's method, with the design's
    assert [type(s).__name__ for s in mine["stylesheets"]] == [type(s).__name__ for s in panels["stylesheets"]]
    assert len(mine["stylesheets"]) > 1 and mine["stylesheets"][-1] == ":host { color: red; }"


def test_install_is_idempotent():
    fastpath.install()
    first = Reactive._update_properties
    fastpath.install()
    assert Reactive._update_properties is first and first._isl_fast
