"""Every patch of Panel, Bokeh and BokehJS internals the dashboard makes, in one table, and the one :func:`install` of
the Python ones, which the server's start-up calls (:func:`app.serving.serve.main`) before any session exists.

A patch replaces a library's own function, method or attribute — Python code in the server process, or a BokehJS
(or Panel JavaScript) prototype method in the browser. Each is listed in :data:`PATCHES` with the targets it
replaces or relies on, the version of the library it was written for and a digest of each target's code in that
version (:func:`digest`: the Python definition's source, the method's TypeScript declaration for the browser's).
``tests/serving/test_patches.py`` compares those digests with the installed libraries and fails, naming the patch
to re-read, when a target changed or disappeared. The development page's "Patches of Panel and Bokeh" says why
each is there; ``docs/upstream/`` holds a drafted report for each.

The views never import the modules that patch (:mod:`app.serving.hardening`, :mod:`app.serving.fastpath`,
:mod:`app.serving.offloop`); what a page needs of the server is in :mod:`app.serving.session`. The browser's patches
are scripts a page sends with itself (:mod:`app.views.a11y`, :mod:`app.views.paint`).
"""

from __future__ import annotations

import ast
import hashlib
import re
from dataclasses import dataclass
from importlib.util import find_spec
from pathlib import Path

__all__ = ["PATCHES", "Patch", "digest", "install"]

#: where the TypeScript declarations of the browser's libraries are installed, by the prefix a target names
_DECLARATIONS = {"bokehjs": ("bokeh", "server/static/js/lib"), "paneljs": ("panel", "dist/lib")}


@dataclass(frozen=True)
class Patch:
    """One patch: ``name`` (the function of ours that installs it), the ``library`` and version it was
    ``written_for``, and ``targets``: each target's name mapped to its :func:`digest` in that version."""

    name: str
    library: str
    written_for: str
    targets: dict[str, str]
    upstream: str  #: the drafted report, under docs/upstream/


PATCHES = (
    Patch(
        "hardening.keep_unsent_models_new",
        "bokeh",
        "3.9.2",
        {"bokeh.document.document:Document.apply_json_patch": "b63b16ed6c653ac8"},
        "bokeh-unsent-models-synced.md",
    ),
    Patch(
        "hardening.serialize_session_events",
        "panel",
        "1.9.4",
        {
            "panel.reactive:Syncable._server_change": "6565b8e7d2e986eb",
            "panel.reactive:Syncable._change_event": "1e6858355b56daf2",
            "panel.reactive:Syncable._process_bokeh_event": "5b4f22203f8abb89",
        },
        "panel-concurrent-events-of-one-session.md",
    ),
    Patch(
        "hardening.per_instance_readonly_edits",
        "panel",
        "1.9.4",
        {
            "panel.util.parameters:edit_readonly": "b448e37019471be5",
            # relied on: Panel's busy counter is edited under it, from every session
            "panel.io.state:_state._add_busy_event": "619ea32fc45e57dd",
        },
        "panel-edit-readonly-shared-parameters.md",
    ),
    Patch(
        "fastpath.serialize_set_properties_only",
        "bokeh",
        "3.9.2",
        {"bokeh.core.has_props:HasProps.query_properties_with_values": "3c62051e2c2db1ce"},
        "bokeh-query-properties-reads-defaults.md",
    ),
    Patch(
        "offloop.install (curdoc per thread, link registry, execute)",
        "bokeh, panel",
        "3.9.2, 1.9.4",
        {
            "bokeh.io.doc:_PATCHED_CURDOCS": "1419335a74ee899c",
            "panel.links:Callback.registry": "fec7e97c512f31ac",
            "panel.io.state:_state.execute": "de29af7574bf9389",
        },
        "panel-documents-built-on-threads.md",
    ),
    Patch(
        "a11y.A11Y_SCRIPT",
        "bokehjs, paneljs",
        "3.9.2, 1.9.4",
        {
            "bokehjs:models/widgets/sliders/abstract_slider:AbstractSliderView.render": "32c880529dee0718",
            "bokehjs:models/widgets/sliders/abstract_slider:AbstractSliderView._update_title": "455da079440826c7",
            "bokehjs:models/widgets/spinner:SpinnerView.render": "32c880529dee0718",
            "bokehjs:models/widgets/checkbox:CheckboxView.render": "32c880529dee0718",
            "bokehjs:models/widgets/toggle_input:ToggleInputView._update_label": "915f8f31f50f85dd",
            "bokehjs:models/layouts/tabs:TabsView._update_headers": "4e47ce71c908305b",
            "bokehjs:models/layouts/tabs:TabsView.update_active": "262fd34f7e4ee43d",
            "bokehjs:core/dom_view:DOMComponentView._update_stylesheets": "51b846e51d89c1fe",
            "bokehjs:models/tools/tool_button:ToolButtonView.render": "32c880529dee0718",
            "bokehjs:models/tools/on_off_button:OnOffButtonView._toggle_active": "b164226614c3a6d7",
            "bokehjs:models/plots/plot_canvas:PlotView.render": "32c880529dee0718",
            "paneljs:models/tooltip_icon:TooltipIconView.render": "32c880529dee0718",
            "paneljs:models/tabs:TabsView.update_active": "262fd34f7e4ee43d",
            "paneljs:models/card:CardView.render": "32c880529dee0718",
            "paneljs:models/card:CardView._collapse": "335e50838dad62a4",
        },
        "bokehjs-widgets-accessible-names.md",
    ),
    Patch(
        "paint.SKIP_SAME_STYLESHEET",
        "bokehjs",
        "3.9.2",
        {"bokehjs:core/dom:InlineStyleSheet._update": "0e37fd6b617bb13d"},
        "bokehjs-inline-stylesheet-same-text.md",
    ),
    Patch(
        "paint.UNTHEMED_CANVAS",
        "bokehjs",
        "3.9.2",
        {"bokehjs:core/visuals/visual:VisualProperties._get_css_value": "bd524febbbbe4157"},
        "bokehjs-css-variable-lookups.md",
    ),
)


def digest(target: str) -> str | None:
    """A short digest of ``target``'s code in the installed library, or None if it is not there.

    ``"module:Qual.name"``: the source of that definition (a function, method, class or assigned name) in the
    module's file, read without importing it (so a target already patched in this process reads as the library
    wrote it). ``"bokehjs:path:Class.method"`` / ``"paneljs:…"``: the line that declares the method in that class of
    the library's TypeScript declarations (``lib/path.d.ts``)."""
    kind, path, name = target.split(":") if target.count(":") == 2 else ("python", *target.split(":"))
    if kind == "python":
        spec = find_spec(path)
        if spec is None or spec.origin is None:
            return None
        text = Path(spec.origin).read_text("utf-8")
        node = _definition(ast.parse(text), name.split("."))
        segment = ast.get_source_segment(text, node) if node is not None else None
    else:
        package, folder = _DECLARATIONS[kind]
        spec = find_spec(package)
        if spec is None or spec.origin is None:
            return None
        declarations = Path(spec.origin).parent / folder / f"{path}.d.ts"
        segment = _declaration(declarations.read_text("utf-8"), *name.split(".")) if declarations.is_file() else None
    return None if segment is None else hashlib.sha256(segment.encode()).hexdigest()[:16]


def _definition(tree: ast.AST, names: list[str]) -> ast.AST | None:
    """The definition of ``names`` (a dotted path: class, then member) in ``tree``'s body."""
    found: ast.AST | None = None
    for node in getattr(tree, "body", []):
        named: list[str | None] = []
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            named = [node.name]
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            named = [getattr(t, "id", None) for t in (node.targets if isinstance(node, ast.Assign) else [node.target])]
        if names[0] in named:
            found = node
    if found is None or len(names) == 1:
        return found
    return _definition(found, names[1:])


def _declaration(text: str, cls: str, method: str) -> str | None:
    """The line declaring ``method`` in ``class cls`` of a TypeScript declaration file."""
    block = re.search(rf"^export declare (?:abstract )?class {cls}\b.*?^}}", text, re.M | re.S)
    line = (
        re.search(rf"^\s*(?:(?:protected|private|public|static)\s+)*{method}\(.*$", block.group(), re.M)
        if block
        else None
    )
    return line.group().strip() if line else None


def install() -> None:
    """Install the Python patches of :data:`PATCHES` (idempotent): hardening's, the fast path's and the threads'; the
    browser's are sent by each page."""
    from . import fastpath, hardening, offloop

    hardening.install()
    offloop.install()
    fastpath.install()
