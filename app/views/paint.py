"""A redraw without needless style work in the browser: BokehJS rewrites each renderer's position stylesheet at every
paint, even when its text is the same.

Every renderer of a plot (lines, band, grids, axes, title) replaces the text of its own ``<style>`` element with its
position at each paint (BokehJS 3.9, ``RendererView.update_position`` → ``InlineStyleSheet._update``). Each
replacement invalidates the page's style; the next visual of the paint reads its colour through
``getComputedStyle`` (canvas theming by CSS variables), and that read recalculates the style of the page, many
times per redraw of the three Fig. 3 plots (bokeh/bokeh#15286 describes the same reads). A rewrite with the text the
element already holds changes nothing, so :data:`SKIP_SAME_STYLESHEET` leaves it out (what it saves:
:ref:`performance-latency`).

BokehJS also looks up a CSS variable (``--bk-line-color``, ``--bk-major-label-text-color``, …) for every visual
property it paints (``VisualProperties._get_css_value``: ``getComputedStyle(el).getPropertyValue``), so that a page can
theme its canvases by CSS; about 1000 lookups per slider change on the trajectories, and each one made after a style
change (the numbers table's new HTML, a renderer's new position) forces the recalculation of the page's style. This
page themes no canvas by CSS — no stylesheet it loads sets a ``--bk-*`` variable (a browser test checks every
stylesheet of the page), so every lookup returned "" and the model's own value was used — and
:data:`UNTHEMED_CANVAS` returns "" without the lookup (what it saves: :ref:`performance-latency`).

The script is a document-ready callback of the session's document: it runs once the page's BokehJS is loaded, before
the plots (built after the page connects) are drawn. If BokehJS no longer has either method (another version), that
part does nothing, and the browser tests of the page (``tests/browser/test_browser_*``) fail on the checks they make.
"""

from __future__ import annotations

from bokeh.models import CustomJS

__all__ = ["SKIP_SAME_STYLESHEET", "UNTHEMED_CANVAS", "skip_same_stylesheet"]

#: installs the skip once per page; ``__isl_skip_same`` marks the installed method (the browser test checks it)
SKIP_SAME_STYLESHEET = """
const dom = window.Bokeh && Bokeh.require ? Bokeh.require("core/dom") : null;
const proto = dom && dom.InlineStyleSheet ? dom.InlineStyleSheet.prototype : null;
if (proto && typeof proto._update === "function" && !proto._update.__isl_skip_same) {
    const update = proto._update;
    proto._update = function (css) {
        if (this.el == null || this.el.textContent !== css) {
            update.call(this, css);
        }
    };
    proto._update.__isl_skip_same = true;
}
"""


#: installs :data:`SKIP_SAME_STYLESHEET`'s companion: no canvas theming through CSS (``__isl_unthemed`` marks it)
UNTHEMED_CANVAS = """
let visual = null;   // (another BokehJS may not have the module: then nothing is skipped, and the browser test fails)
try { visual = Bokeh.require("core/visuals/visual"); } catch (e) { visual = null; }
const vproto = visual && visual.VisualProperties ? visual.VisualProperties.prototype : null;
if (vproto && typeof vproto._get_css_value === "function" && !vproto._get_css_value.__isl_unthemed) {
    const unthemed = function (name) { return ""; };
    unthemed.__isl_unthemed = true;
    vproto._get_css_value = unthemed;
}
"""


def skip_same_stylesheet(doc) -> None:
    """Install :data:`SKIP_SAME_STYLESHEET` in the browser when ``doc`` is ready (nothing without a document)."""
    if doc is not None:
        doc.js_on_event("document_ready", CustomJS(code=SKIP_SAME_STYLESHEET + UNTHEMED_CANVAS))
