"""Less Python on the event loop when a page's models are serialized: a bokeh method that computes what it then
throws away.

To serialize a model bokeh 3.9 (``HasProps.query_properties_with_values`` with ``include_defaults=False``) reads the
value of every property — computing the default of each one never set — and then keeps only those set, themed or with
a per-instance default ("TODO: this should happen before get_value()", its source says). Serializing a page's models
happens on the event loop when the page connects and when a part is swapped in. :func:`serialize_set_properties_only`
reads only the values it keeps; for the others it still reads a value that may be unset (no default), so a model with
a required property left unset is refused as before. A test compares both methods on every model of a fully built
page; what it saves the event loop: :ref:`performance-serving`.

:func:`install` is idempotent; :func:`app.serving.patches.install` calls it at the server's start-up. (The markup
panes' stylesheets given while the page is built, which changes no library code, are
:func:`app.serving.session.settle_markup_stylesheets`.)
"""

from __future__ import annotations

from typing import Any

from .mark import mark

__all__ = ["install", "serialize_set_properties_only"]


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


def install() -> None:
    """Install the patch (idempotent)."""
    serialize_set_properties_only()
