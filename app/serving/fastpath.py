"""Less Python per change in the server: two library methods that compute what they then throw away.

**Design stylesheets.** Panel recomputes a component's design stylesheets on every change of any of its parameters,
and uses them only when the change is to ``stylesheets`` itself.

Panel 1.9's ``Reactive._update_properties`` starts with ``self._design.params(self, doc)``, which resolves the design's
modifiers and builds bokeh stylesheet models, then merges those stylesheets into the change only if the change
includes ``stylesheets``. Every browser event (a slider's ``value``) and every outcome applied to a pane runs it: in a
profile of 22 σ changes in the served page, it was 44 of the events' calls and a quarter of their time on Panel's
thread, and again on the event loop for each updated pane. :func:`skip_unused_design_params` computes them only when
``stylesheets`` changes; the properties sent are the same (a test compares both methods' results).

**Defaults of properties that are not sent.** To serialize a model bokeh 3.9 (``HasProps.query_properties_with_values``
with ``include_defaults=False``) reads the value of every property — computing the default of each one never set —
and then keeps only those set, themed or with a per-instance default ("TODO: this should happen before get_value()",
its source says). Serializing new models is most of what a page's parts cost the event loop when they are swapped in
after the page connects (four parts a page). :func:`serialize_set_properties_only` reads only the
values it keeps; for the others it still reads a value that may be unset (no default), so a model with a required
property left unset is refused as before. A test compares both methods on every model of a fully built page. What
it saves the event loop: :ref:`performance-serving`.

**References of the models the browser has.** Every ``PATCH-DOC`` message starts with a ``Serializer`` told which
models the browser already has, so that it names them by id: bokeh 3.9 builds ``{id(model): model.ref}`` for every
model of the page (≈ 2000 on the dashboard's page) although a message names a few dozen. In a profile of the event
loop while σ moved, that comprehension was 205 of the ≈ 3000 busy samples (as much as encoding the messages).
:func:`lazy_serializer_references` keeps ``{id(model): model}`` and makes the ref only of a model a message names; a
test compares whole messages made both ways.

:func:`install` is idempotent; :func:`app.serving.patches.install` calls it at the server's start-up. (The markup
panes' stylesheets given while the page is built, which changes no library code, are
:func:`app.serving.session.settle_markup_stylesheets`.)
"""

from __future__ import annotations

from typing import Any

from .mark import mark

__all__ = [
    "install",
    "lazy_serializer_references",
    "serialize_set_properties_only",
    "skip_unused_design_params",
]


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

    mark(update_properties, _isl_fast=True, _isl_original=original)
    Reactive._update_properties = update_properties


def serialize_set_properties_only() -> None:
    """Replace ``HasProps.query_properties_with_values`` by one that, without defaults, reads only what it returns."""
    from bokeh.core.has_props import HasProps
    from bokeh.core.property.descriptors import UnsetValueError
    from bokeh.core.property.singletons import Undefined
    from bokeh.core.property.wrappers import PropertyValueContainer

    original = HasProps.query_properties_with_values
    if getattr(original, "_isl_fast", False):
        return

    def query_properties_with_values(self, query, *, include_defaults: bool = True, include_undefined: bool = False):
        if include_defaults:
            return original(self, query, include_defaults=include_defaults, include_undefined=include_undefined)
        themed = self.themed_values()
        themed_keys = set(themed) if themed is not None else set()
        selected = set(self._property_values) | set(self._unstable_default_values) | themed_keys
        overridden = None
        result: dict[str, Any] = {}
        for key in self.properties(_with_props=True):
            descriptor = self.lookup(key)
            if not query(descriptor):
                continue
            if key not in selected:  # left out unless it has no value at all, as bokeh's own method decides
                if descriptor.property._default is not Undefined:
                    continue
                overridden = type(self)._overridden_defaults() if overridden is None else overridden
                if key in overridden:
                    continue
            try:
                value = descriptor.get_value(self)
            except UnsetValueError:
                if not include_undefined:
                    raise
                value = Undefined
            else:
                if key not in selected:
                    continue
                if (
                    key not in themed_keys
                    and isinstance(value, PropertyValueContainer)
                    and key in self._unstable_default_values
                ):
                    continue
            result[key] = value
        return result

    mark(query_properties_with_values, _isl_fast=True, _isl_original=original)
    HasProps.query_properties_with_values = query_properties_with_values  # type: ignore[method-assign]  # the patch


class _Refs(dict):
    """``id(model) -> model.ref`` for the models the browser has, each ref made when it is first asked for (the
    entries bokeh adds itself are refs already)."""

    def get(self, key, default=None):
        value = dict.get(self, key, default)
        return value if value is default or isinstance(value, dict) else value.ref

    def __getitem__(self, key):
        value = dict.__getitem__(self, key)
        return value if isinstance(value, dict) else value.ref


def lazy_serializer_references() -> None:
    """Make ``Serializer(references=...)`` keep the models and make their refs on demand."""
    from bokeh.core.serialization import Serializer

    original = Serializer.__init__
    if getattr(original, "_isl_fast", False):
        return

    def __init__(self, *, references=frozenset(), deferred: bool = True, check_circular: bool = False) -> None:
        original(self, deferred=deferred, check_circular=check_circular)
        self._references = _Refs({id(model): model for model in references})

    mark(__init__, _isl_fast=True, _isl_original=original)
    Serializer.__init__ = __init__


def install() -> None:
    """Install the three patches (idempotent)."""
    skip_unused_design_params()
    serialize_set_properties_only()
    lazy_serializer_references()
