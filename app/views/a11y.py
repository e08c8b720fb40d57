"""A page anyone can operate: keyboard, screen reader, visible focus — what BokehJS and the template leave out.

BokehJS 3.9 and Panel's Fast list template draw the widgets this page uses without some of what WCAG 2.1 AA asks of
them. :data:`A11Y_SCRIPT` runs in the browser when the page's document is ready, adds what is missing to the BokehJS
views of the page (those drawn already and, through their prototypes, those drawn later) and to the template:

* **sliders** get an accessible name (their title, or a longer one from :data:`SLIDER_NAMES`) and announce the value
  they show — a log-scale slider's handle says "20", not its position 1.30 (noUiSlider's ``aria-valuetext`` is
  rewritten after its own update);
* **tabs** are a tab list: ``role="tab"`` with ``aria-selected``, one tab stop (the open tab) that comes before the
  panel's content (BokehJS puts the headers after it), the arrow keys, Home and End move between tabs, Enter and
  Space open the focused one (WAI-ARIA's tabs pattern, manual activation: a tab is built when first opened, so
  moving through them does not build each one); a card's header button says whether the card is open;
* **plots**: a plot's canvas, which takes the keyboard focus for key tools none of these plots has, leaves the tab
  order (two stops a plot before) and is the plot is a group named by its title; its toolbar's buttons are buttons
  (named by their tooltip, pressed or not);
* the **help icons** ("?") take the keyboard focus, show their help on focus and are named by it;
* **checkboxes** are named by their label, and a click on the label ticks them; the spinners' up/down buttons are
  named and left out of the tab order (the arrow keys step the number in the box);
* **focus** is visible everywhere: :data:`FOCUS_CSS` goes into every BokehJS view's shadow root (each widget, plot
  and toolbar draws in its own), and :data:`PAGE_CSS` into the page;
* **the template**: a "Skip to the views" link first in the tab order (it focuses the open tab: the controls of the
  sidebar and the plots' toolbars come before the tabs otherwise), the sidebar's toggle is a button reachable by
  keyboard that says whether the sidebar is open, the sidebar folded away (presenter mode) is ``inert`` — out of the
  tab order and hidden from screen readers until it is unfolded —, the main area and the sidebar are landmarks, and
  the sidebar's list holds no list items (``role=none``); the presenter toggle, which reloads the page, has the focus
  again after the reload.

If BokehJS no longer has what a part patches (another version), that part does nothing, and the browser tests fail on
what they check (axe-core's rules and the keyboard walk in ``tests/test_browser_a11y.py``).
"""

from __future__ import annotations

from bokeh.models import CustomJS

__all__ = ["A11Y_SCRIPT", "FOCUS_CSS", "PAGE_CSS", "SLIDER_NAMES", "install"]

#: a focus ring seen on white (black) and on the blue header (white around it): 3 px, outside the element
FOCUS_CSS = """
:focus-visible, :host(:focus-visible) {
  outline: 3px solid #111 !important; outline-offset: 2px !important; box-shadow: 0 0 0 6px #fff !important;
}
input:focus-visible, select:focus-visible, textarea:focus-visible, .bk-tab:focus-visible {
  outline-offset: -3px !important; box-shadow: none !important;
}
"""

#: the page's own rules: the skip link (off screen until focused), the focus ring outside the shadow roots
PAGE_CSS = (
    FOCUS_CSS
    + """
.isl-skip { position: absolute; left: -10000px; top: 8px; z-index: 10000; background: #fff; color: #111;
            padding: 8px 14px; font-size: 16px; border-radius: 4px; }
.isl-skip:focus { left: 8px; }
#sidebar-button { cursor: pointer; }
"""
)

#: accessible names of the sliders, by their visible title (the title alone is a symbol such as "σ")
SLIDER_NAMES = {
    "α": "α, damping of the top derivative",
    "w": "w, stationary spread of the top derivative",
    "β": "β, intensity of the noise driving the top derivative",
    "σ": "σ, observation noise intensity",
    "ν": "ν, the ISL filter's tuning knob",
    "m (state dimension)": "m, state dimension",
}

A11Y_SCRIPT = r"""
const need = (name) => { try { return Bokeh.require(name); } catch (e) { return null; } };
const MARK = "__isl_a11y";
const after = (proto, method, hook) => {   // run hook(this) after proto[method], once per prototype
    const original = proto && proto[method];
    if (typeof original !== "function" || original[MARK]) return;
    const wrapped = function (...args) {
        const out = original.apply(this, args);
        try { hook.call(this); } catch (e) { console.error("isl a11y", e); }
        return out;
    };
    wrapped[MARK] = true;
    proto[method] = wrapped;
};
const views = () => (window.Bokeh && Bokeh.index ? Array.from(Bokeh.index.all_views()) : []);
const view_class = (type) => {   // the view class of a model type (Panel's own, which Bokeh.require does not load)
    try { const M = Bokeh.Models.get(type); return M && M.prototype.default_view ? M.prototype.default_view : null; }
    catch (e) { return null; }
};
const text_of = (title) => (typeof title === "string" ? title.trim() : "");

function label_slider() {
    const handle = this.slider_el && this.slider_el.querySelector(".noUi-handle");
    if (!handle) return;
    const title = text_of(this.model.title).replace(/ \(ticked below\)$/, "");
    if (title) handle.setAttribute("aria-label", names[title] || title);
    const shown = (v) => { try { return String(this.pretty(v)); } catch (e) { return String(v); } };
    handle.setAttribute("aria-valuetext", shown(this.model.value));
    if (this._noUiSlider && !this.__isl_aria) {
        this.__isl_aria = true;
        this._noUiSlider.on("update.isl", (values, i, unencoded) => {
            const h = this.slider_el.querySelectorAll(".noUi-handle")[i];
            // the handle sits on the step grid; the title shows the model's value, which may lie between steps
            const v = Math.abs(unencoded[i] - this.model.value) <= (this.model.step || 0) / 2 ? this.model.value
                : unencoded[i];
            if (h) h.setAttribute("aria-valuetext", shown(v));
        });
    }
}

function label_spinner() {
    const title = text_of(this.model.title) || "the value";
    for (const [el, word] of [[this.btn_up_el, "Increase"], [this.btn_down_el, "Decrease"]]) {
        if (el) { el.setAttribute("aria-label", `${word} ${title}`); el.tabIndex = -1; }
    }
}

function label_checkbox() {
    if (!this.checkbox_el) return;
    const text = text_of(this.model.label);
    if (text) this.checkbox_el.setAttribute("aria-label", text);
    if (this.label_el && !this.label_el.__isl_click) {
        this.label_el.__isl_click = true;
        this.label_el.style.cursor = "pointer";
        this.label_el.addEventListener("click", () => { if (!this.model.disabled) this.checkbox_el.click(); });
    }
}

function tab_list() {
    const headers = this.header_els || [];
    // BokehJS appends the tab headers after the panels (the grid puts them on top): in the tab order they came after
    // every control and plot toolbar of the open panel. First in the shadow root, they come first.
    if (this.header_el && this.shadow_el && this.shadow_el.firstChild !== this.header_el) {
        const first = Array.from(this.shadow_el.children).find((el) => el.tagName !== "STYLE");
        if (first && first !== this.header_el) this.shadow_el.insertBefore(this.header_el, first);
    }
    if (this.headers_wrapper_el) this.headers_wrapper_el.setAttribute("role", "tablist");
    const active = this.model.active;
    headers.forEach((el, i) => {
        el.setAttribute("role", "tab");
        el.setAttribute("aria-selected", String(i === active));
        el.tabIndex = i === active ? 0 : -1;
        if (el.__isl_keys) return;
        el.__isl_keys = true;
        el.addEventListener("keydown", (event) => {
            const all = this.header_els, n = all.length, at = all.indexOf(el);
            const to = {ArrowRight: at + 1, ArrowDown: at + 1, ArrowLeft: at - 1, ArrowUp: at - 1, Home: 0,
                        End: n - 1}[event.key];
            this.__isl_keyed_at = performance.now();
            if (event.key === "Enter" || event.key === " ") {
                event.preventDefault();
                this.change_active(at);
            } else if (to !== undefined) {
                event.preventDefault();
                all[(to + n) % n].focus();
            }
        });
    });
    // Panel sends the tab list anew when a tab opens, and the focused header is replaced: a keyboard user's focus
    // goes to the open tab's new header instead of the top of the page
    const keyed = performance.now() - (this.__isl_keyed_at || -Infinity) < 5000;
    if (keyed && this.shadow_el && !this.shadow_el.activeElement && headers[active]) headers[active].focus();
    (this.child_views || []).forEach((view, i) => {
        if (!view || !view.el) return;
        view.el.setAttribute("role", "tabpanel");
        const tab = this.model.tabs[i];
        if (tab) view.el.setAttribute("aria-label", tab.title);
    });
}

function plot_name() {
    // a plot's canvas takes keyboard focus for key tools, which these plots have none of: out of the tab order
    // (two stops a plot), named by the plot's title for a screen reader, whose text alternative is the numbers
    const events = this.canvas_view && this.canvas_view.events_el;
    if (events) events.tabIndex = -1;
    const title = this.model.title && typeof this.model.title.text === "string" ? this.model.title.text : "";
    this.el.setAttribute("role", "group");   // a group: it holds the toolbar's buttons
    this.el.setAttribute("aria-label", title ? `Plot: ${title}` : "Plot legend");
}

function tool_button() {
    this.el.setAttribute("role", "button");
    if (this.el.title) this.el.setAttribute("aria-label", this.el.title);
    if (this.model.tool && "active" in this.model.tool && this.class_list) {
        this.el.setAttribute("aria-pressed", String(Boolean(this.model.tool.active)));
    }
}

function help_icon() {
    // the "?" beside an input showed its help on hover only: focusable, it shows it on focus and names it
    const el = this.desc_el, tip = this.model.description;
    if (!el || !tip || el.__isl_keys) return;
    el.__isl_keys = true;
    el.tabIndex = 0;
    el.setAttribute("role", "button");
    const raw = typeof tip.content === "string" ? tip.content : (tip.content && tip.content.html) || "";
    const html = Array.isArray(raw) ? raw.filter((x) => typeof x === "string").join(" ") : String(raw);
    const text = new DOMParser().parseFromString(html, "text/html").body.textContent.trim();
    el.setAttribute("aria-label", `Help: ${text}`);
    el.addEventListener("focus", () => tip.setv({visible: true}));
    el.addEventListener("blur", () => tip.setv({visible: false}));
    el.addEventListener("keydown", (event) => { if (event.key === "Escape") tip.setv({visible: false}); });
}

function card_state() {
    if (!this.button_el) return;
    this.button_el.setAttribute("aria-expanded", String(!this.model.collapsed));
    const text_in = (view) => !view ? "" : typeof view.model.text === "string" ? view.model.text
        : (view.child_views || []).map(text_in).join(" ");
    const text = text_in(this.child_views && this.child_views[0]);
    const decoded = new DOMParser().parseFromString(text, "text/html").body.textContent;   // Panel escapes its HTML
    const name = new DOMParser().parseFromString(decoded, "text/html").body.textContent.trim();
    if (name) this.button_el.setAttribute("aria-label", name);   // its title sits in the header's own shadow root
}

function focus_ring() {
    if (this.shadow_el instanceof ShadowRoot && !this.__isl_focus) {
        this.__isl_focus = true;
        this._apply_stylesheets([focus_css]);
    }
}

function patch() {
    const slider = need("models/widgets/sliders/abstract_slider");
    if (slider) {
        after(slider.AbstractSliderView.prototype, "render", label_slider);
        after(slider.AbstractSliderView.prototype, "_update_title", label_slider);
    }
    const spinner = need("models/widgets/spinner");
    if (spinner) after(spinner.SpinnerView.prototype, "render", label_spinner);
    const checkbox = need("models/widgets/checkbox");
    if (checkbox) {
        after(checkbox.CheckboxView.prototype, "render", label_checkbox);
        after(checkbox.CheckboxView.prototype, "_update_label", label_checkbox);
    }
    const tabs = need("models/layouts/tabs");
    if (tabs) {
        after(tabs.TabsView.prototype, "_update_headers", tab_list);
        after(tabs.TabsView.prototype, "update_active", tab_list);
    }
    const dom_view = need("core/dom_view");
    if (dom_view) {   // a view that renders again empties its shadow root: the ring is installed anew
        after(dom_view.DOMComponentView.prototype, "_update_stylesheets", function () {
            this.__isl_focus = false;
            focus_ring.call(this);
        });
    }
    const button = need("models/tools/tool_button"), on_off = need("models/tools/on_off_button");
    if (button) after(button.ToolButtonView.prototype, "render", tool_button);
    if (on_off) after(on_off.OnOffButtonView.prototype, "_toggle_active", tool_button);
    const plot = need("models/plots/plot_canvas");
    if (plot) after(plot.PlotView.prototype, "render", plot_name);
    const help = view_class("panel.models.widgets.TooltipIcon");
    if (help) after(help.prototype, "render", help_icon);
    const panel_tabs = view_class("panel.models.tabs.Tabs");   // it has an update_active of its own
    if (panel_tabs) after(panel_tabs.prototype, "update_active", tab_list);
    const card = view_class("panel.models.layout.Card");
    if (card) {
        after(card.prototype, "render", card_state);
        after(card.prototype, "_collapse", card_state);
    }
    for (const view of views()) {   // the views drawn before this script ran
        focus_ring.call(view);
        if (slider && view instanceof slider.AbstractSliderView) label_slider.call(view);
        if (spinner && view instanceof spinner.SpinnerView) label_spinner.call(view);
        if (checkbox && view instanceof checkbox.CheckboxView) label_checkbox.call(view);
        if (tabs && view instanceof tabs.TabsView) tab_list.call(view);
        if (plot && view instanceof plot.PlotView) plot_name.call(view);
        if (button && view instanceof button.ToolButtonView) tool_button.call(view);
        if (help && view instanceof help) help_icon.call(view);
        if (card && view instanceof card) card_state.call(view);
    }
}

function template() {
    document.querySelectorAll("ul.nav").forEach((ul) => ul.setAttribute("role", "none"));
    const main = document.getElementById("main");
    if (main) main.setAttribute("role", "main");
    const sidebar = document.getElementById("sidebar");
    if (sidebar) { sidebar.setAttribute("role", "complementary"); sidebar.setAttribute("aria-label", "Controls"); }
    const toggle = document.getElementById("sidebar-button");
    if (sidebar && !sidebar.__isl_fold) {   // folded away (class "hidden"): out of the tab order and unseen by readers
        sidebar.__isl_fold = true;
        const fold = () => {
            const folded = sidebar.classList.contains("hidden");
            sidebar.inert = folded;
            if (toggle) toggle.setAttribute("aria-expanded", String(!folded));
        };
        new MutationObserver(fold).observe(sidebar, {attributes: true, attributeFilter: ["class"]});
        fold();
    }
    if (toggle && !toggle.__isl_keys) {
        toggle.__isl_keys = true;
        toggle.setAttribute("role", "button");
        toggle.tabIndex = 0;
        toggle.setAttribute("aria-label", "Show or hide the controls");
        toggle.addEventListener("keydown", (event) => {
            if (event.key === "Enter" || event.key === " ") { event.preventDefault(); toggle.click(); }
        });
    }
    if (!document.getElementById("isl-skip")) {
        const skip = document.createElement("a");
        skip.id = "isl-skip";
        skip.className = "isl-skip";
        skip.href = "#main";
        skip.textContent = "Skip to the views";
        skip.addEventListener("click", (event) => {
            event.preventDefault();
            const tabs = views().find((v) => v.header_els && v.model.type.endsWith("Tabs"));
            const el = tabs && tabs.header_els[tabs.model.active];
            if (el) el.focus();
        });
        document.body.prepend(skip);
    }
}

function refocus_toggle() {
    // the presenter toggle reloads the page: a keyboard user's focus goes back to it, not to the top of the page
    let wanted = null;
    try { wanted = sessionStorage.getItem("isl-focus"); sessionStorage.removeItem("isl-focus"); } catch (e) {}
    if (wanted !== "presenter") return;
    let tries = 0;
    const focus = () => {   // the header's toggle may be drawn a moment after the document is ready
        const toggle = views().find((v) => v.button_el && /presenter mode/i.test(v.model.label || ""));
        if (toggle) toggle.button_el.focus();
        else if (tries++ < 100) setTimeout(focus, 50);
    };
    focus();
}

patch();
template();
refocus_toggle();
"""


def install(doc) -> None:
    """Run :data:`A11Y_SCRIPT` in the browser when ``doc`` is ready (nothing without a document)."""
    if doc is not None:
        doc.js_on_event(
            "document_ready", CustomJS(code=A11Y_SCRIPT, args={"names": SLIDER_NAMES, "focus_css": FOCUS_CSS})
        )
