"""Less library work when the server serializes a page (app.serving.fastpath): the same properties are sent, less is
computed; and the markup panes' stylesheets settled while the page is built (app.serving.session)."""

from __future__ import annotations

import panel as pn
import pytest
from bokeh.core.has_props import HasProps
from bokeh.document import Document

from app.serving import fastpath, session


def test_install_is_idempotent():
    fastpath.install()
    first = HasProps.query_properties_with_values
    fastpath.install()
    assert HasProps.query_properties_with_values is first and first._isl_fast


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
