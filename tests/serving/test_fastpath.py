"""Less library work per change in the server (app.serving.fastpath): the same properties are sent, less is computed."""

from __future__ import annotations

import panel as pn
import param
import pytest
from bokeh.document import Document
from panel.reactive import Reactive

from app.serving import fastpath, session


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


def _every_part_of_the_page(doc: Document) -> None:
    """Every view of the dashboard, built in ``doc`` (jobs inline)."""
    from panel.io.state import set_curdoc

    from app.state import AppState
    from app.views import ControlsView, NumbersView, SweepView, TrajectoriesView, about_card
    from app.views.compare import CompareView
    from app.views.filters_panel import FiltersPanel
    from app.views.scenario import ScenarioView
    from app.views.worstcase import WorstCaseView

    with set_curdoc(doc):
        state = AppState()
        state.start()
        views = [
            TrajectoriesView,
            NumbersView,
            ControlsView,
            FiltersPanel,
            SweepView,
            WorstCaseView,
            CompareView,
            ScenarioView,
        ]
        page = pn.Column(*(view(state=state) for view in views), about_card(), design=pn.theme.Fast)
        doc.add_root(page.get_root(doc))


def test_serialization_reads_only_what_it_sends_and_sends_what_bokeh_sends():
    """Every model of a fully built page: the properties serialized (without defaults, with and without the unset
    ones) are bokeh's own, and a required property left unset is still refused."""
    from bokeh.core.has_props import HasProps
    from bokeh.core.property.descriptors import UnsetValueError
    from bokeh.models import Slider

    fastpath.install()
    fast = HasProps.query_properties_with_values
    original = fast._isl_original
    serialized = lambda prop: prop.serialized  # noqa: E731 — bokeh's query for serialization
    doc = Document()
    _every_part_of_the_page(doc)
    models = list(doc.models)
    assert len(models) > 500
    for model in models:
        for undefined in (False, True):
            mine = fast(model, serialized, include_defaults=False, include_undefined=undefined)
            bokehs = original(model, serialized, include_defaults=False, include_undefined=undefined)
            assert list(mine) == list(bokehs), type(model).__name__
            assert all(mine[k] is bokehs[k] or mine[k] == bokehs[k] for k in mine), type(model).__name__
    unset = Slider(start=0.0, end=1.0, step=0.1)  # its value is required and was never set
    for method in (fast, original):
        with pytest.raises(UnsetValueError, match="value"):
            method(unset, serialized, include_defaults=False)


def test_patch_messages_are_bokehs_own_with_refs_made_on_demand(monkeypatch):
    """A change that names old models (by id) and attaches new ones (in full), on a fully built page: the message,
    its buffers and which models count as sent afterwards are the same with bokeh's serializer."""
    import json

    import numpy as np
    from bokeh.core.serialization import Buffer, Serializer
    from bokeh.models import ColumnDataSource, Div, Row, Slider
    from bokeh.protocol import Protocol

    fastpath.install()
    lazy, original = Serializer.__init__, Serializer.__init__._isl_original
    doc = Document()
    _every_part_of_the_page(doc)
    doc.to_json()  # the browser has every model now
    events = []
    doc.on_change(lambda event: events.append(event))
    old = [m for m in doc.models if isinstance(m, Slider)][:3]
    source = next(m for m in doc.models if isinstance(m, ColumnDataSource))
    root = doc.roots[0]
    root.children = [*root.children, Row(children=[*old, Div(text="new")])]
    source.data = {name: np.arange(50, dtype=np.float32) for name in source.data} or {"x": np.arange(3.0)}
    assert len(events) == 2 and len(old) == 3
    unsent = set(doc.models._new_models)
    assert unsent
    made = {}
    for name, init in (("bokeh", original), ("lazy", lazy)):
        doc.models._new_models = set(unsent)
        monkeypatch.setattr(Serializer, "__init__", init)
        message = Protocol().create("PATCH-DOC", events)
        made[name] = (message.content, [b.to_bytes() for b in message.buffers], set(doc.models._new_models))
    assert made["lazy"][1:] == made["bokeh"][1:]
    as_json = lambda o: "buffer" if isinstance(o, Buffer) else f"not JSON: {o!r}"  # noqa: E731 (ids: per message)
    same = lambda content: json.dumps(content, default=as_json)  # noqa: E731
    assert same(made["lazy"][0]) == same(made["bokeh"][0])
    assert {"id": old[0].id} in _refs(made["lazy"][0])  # an old model by id, the new ones in full
    assert not made["lazy"][2]


def _refs(content) -> list:
    """Every dict inside ``content``."""
    found, todo = [], [content]
    while todo:
        item = todo.pop()
        if isinstance(item, dict):
            found.append(item)
            todo.extend(item.values())
        elif isinstance(item, list | tuple):
            todo.extend(item)
    return found


def _page_with_html(doc: Document) -> pn.pane.HTML:
    """An HTML pane in the dashboard's template and design, built in ``doc``."""
    from app.page import LocalFast

    pane = pn.pane.HTML("<b>first</b>")
    pn.template.FastListTemplate(title="t", main=[pn.Column(pane)], design=LocalFast).server_doc(doc)
    return pane


def test_a_settled_markup_panes_first_update_does_not_re_walk_the_page(monkeypatch):
    """Panel builds a markup pane's model with other stylesheets than its updates send: unsettled, the first update
    of the pane's text re-walks every model of the page (bokeh's ``recompute``); settled, none does, and the model
    has what an update would have given it."""
    from bokeh.document.models import DocumentModelManager
    from panel.io.state import set_curdoc

    walks: list = []
    recompute = DocumentModelManager.recompute
    monkeypatch.setattr(DocumentModelManager, "recompute", lambda self: walks.append(self) or recompute(self))
    plain, settled = Document(), Document()
    with set_curdoc(plain):
        pane = _page_with_html(plain)
        walks.clear()
        pane.object = "<b>second</b>"
        assert len(walks) == 1  # why the settling exists (if Panel stops doing this, it can go)
    with set_curdoc(settled):
        pane = _page_with_html(settled)
        walks.clear()
        session.settle_markup_stylesheets(settled)
        assert len(walks) <= 1  # every pane settled in one walk
        model = next(iter(pane._models.values()))[0]
        assert model.stylesheets == pane._get_properties(settled)["stylesheets"]
        walks.clear()
        pane.object = "<b>second</b>"
        assert walks == [] and "second" in model.text
