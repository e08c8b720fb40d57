"""No stylesheet of a served page points at Panel's CDN, even where Panel updates a part whose models are not in the
page: a part built ahead of being shown (:func:`app.serving.session.prebuild`) and a hidden tab's content.

Panel updates a markup pane (HTML, Markdown, Alert) with the stylesheets of ``_get_properties(model.document)``; a
model outside the page has no document, and Panel then made the design's theme stylesheets anew on its CDN and
pointed the page's own shared ones (``loading.css``) at it too. The who-wins map's page once asked
cdn.holoviz.org for ``theme/default.css`` and ``theme/fast.css``: the Scenarios part, built on a thread, had its
periods table updated by the scenario picture that arrived before the part was shown.
"""

from __future__ import annotations

from types import SimpleNamespace

import panel as pn
import pytest
from bokeh.document import Document
from bokeh.io.doc import patch_curdoc
from bokeh.models import ImportedStyleSheet
from panel.io.resources import CDN_DIST
from panel.io.state import set_curdoc, state

from app.page import LocalFast
from app.serving import session


def on_cdn(models) -> list[str]:
    """The stylesheets among ``models`` (and what they reference) that point at Panel's CDN, by model and URL."""
    found = set()
    for model in models:
        for sheet in model.references():
            if isinstance(sheet, ImportedStyleSheet) and str(sheet.url).startswith(CDN_DIST):
                found.add(f"{type(model).__name__} {model.id}: {sheet.url}")
    return sorted(found)


@pytest.fixture
def page():
    """A served session's document (a request without query, no websocket session yet: updates apply at once, as on
    the session's loop), named the server's files first, as the app script does, with the dashboard's design and a
    tab whose part is built apart: (doc, tabs, the first tab's pane, the second tab's holder)."""
    context = SimpleNamespace(id="a-page", server_context=None, token_payload={})
    context.request = SimpleNamespace(arguments={}, cookies={}, headers={})
    doc = Document()
    doc._session_context = lambda: context
    session.serve_panel_files(doc)
    with set_curdoc(doc), patch_curdoc(doc):
        numbers = pn.pane.HTML("<table><td>1</td></table>")
        holder = pn.Column(pn.pane.Markdown("Building …"))
        tabs = pn.Tabs(("Trajectories", pn.Column(numbers)), ("Scenarios", holder), dynamic=True)
        pn.template.FastListTemplate(main=[tabs], design=LocalFast).server_doc(doc)
        assert on_cdn(doc.roots) == []
        yield doc, tabs, numbers, holder
    for ref in [ref for ref, view in state._views.items() if view[2] is doc]:
        del state._views[ref]


def test_a_part_updated_before_it_is_shown_keeps_the_servers_stylesheets(page):
    doc, tabs, _, holder = page
    periods = pn.pane.HTML("")
    part = pn.Column(periods)  # built on a thread, its models too
    tabs.active = 1
    session.prebuild(part, holder)
    periods.object = "<table><td>2</td></table>"  # an outcome applied before the part is swapped in
    assert on_cdn(doc.roots) == []  # the page's own, shared sheets (loading.css) stay on the server
    assert on_cdn(model for model, _ in periods._models.values()) == []
    holder.objects = [part]
    assert on_cdn(doc.roots) == []


def test_a_hidden_tabs_part_updated_keeps_the_servers_stylesheets(page):
    doc, tabs, numbers, _ = page
    tabs.active = 1  # the first tab's models leave the page
    (model, _), *_ = numbers._models.values()
    assert model.document is None
    numbers.object = "<table><td>3</td></table>"  # a run's numbers, arrived while another tab is open
    assert on_cdn(doc.roots) == []
    assert on_cdn([model]) == []
    tabs.active = 0
    assert on_cdn(doc.roots) == []
