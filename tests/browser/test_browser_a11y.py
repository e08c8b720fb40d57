"""A page anyone can operate (WCAG 2.1 AA): axe-core's rules on every view of the page, and a keyboard-only walk.

axe-core (pinned in ``tests/js/package-lock.json``, installed by ``./scripts/test``) is injected into the served page
and run with the WCAG 2.0/2.1 A and AA rules on each state a class sees: the trajectories at a projector's size, each
tab opened and built in both modes at 1280 × 720 (then the rules the window's size changes at 1920 × 1080), scrolled
through so that every control has been in view (axe measures the contrast of text in view only), refusals on screen, the
who-wins map and the comparison picture drawn. Canvas content is beyond axe: the plots' text is checked by what BokehJS
holds (``test_browser_truth.py``) and the map's colours by their computed contrast (``test_app_scenario.py``). The walk
uses the keyboard alone: the skip link, the tabs (arrow keys, Enter, Space), a visible focus ring at every stop, sliders
that say what they show, no stop on the controls presenter mode has folded away.
"""

from __future__ import annotations

import pytest
from _browser import ROOT, TAB_OPEN, dashboard

pytestmark = [pytest.mark.browser]

AXE = ROOT / "tests" / "js" / "node_modules" / "axe-core" / "axe.min.js"
WCAG_AA = ["wcag2a", "wcag2aa", "wcag21a", "wcag21aa"]

#: axe's violations of the page as it is now: [rule, impact, help, [target, summary] of up to 3 nodes]
AXE_RUN = """async (tags) => { const r = await axe.run(document, {runOnly: {type: 'tag', values: tags}});
    return r.violations.map(v => [v.id, v.impact, v.help,
        v.nodes.slice(0, 3).map(n => [n.target.join(' '), (n.failureSummary || '').slice(0, 200)])]); }"""


def violations(page, rules: list[str] | None = None) -> list:
    """axe-core's WCAG 2.1 AA violations of ``page`` (axe injected once per page), or those of ``rules`` only."""
    assert AXE.exists(), f"axe-core is not installed at {AXE}: run ./scripts/test"
    if not page.evaluate("() => typeof window.axe === 'object'"):
        page.add_script_tag(path=str(AXE))
    if rules:
        return page.evaluate(AXE_RULES, rules)
    return page.evaluate(AXE_RUN, WCAG_AA)


#: the same as :data:`AXE_RUN` for some rules only
AXE_RULES = AXE_RUN.replace("{runOnly: {type: 'tag', values: tags}}", "{runOnly: {type: 'rule', values: tags}}")


def open_tab(page, title: str) -> None:
    """Open the tab titled ``title`` and wait until its part is built (a tab first opened says "Building …" until its
    part, built on a worker thread, is swapped in), so that what is checked is the part itself."""
    page.get_by_role("tab", name=title).click()
    page.wait_for_function(f"() => ({TAB_OPEN})({title!r})", timeout=60_000)
    page.get_by_text(f"Building “{title}” …").wait_for(state="hidden", timeout=60_000)


def test_every_view_of_the_page_meets_wcag_2_1_aa(app_server):
    """Before: sliders without a name, checkboxes without labels, unnamed spinner buttons, a template list holding
    divs, white on green buttons at 2.5 : 1, code at 2.3 : 1, the map's white on cyan or yellow at 2.1 : 1."""
    url, _ = app_server
    found = {}
    requested: list[str] = []
    query = "?seed=-5&sc_runs=2&sc_horizon=8&sc_map=tails&sc_map_seeds=2"  # a refusal on screen from the start
    origin = url.rsplit("/", 1)[0]
    with dashboard(url + query, viewport={"width": 1280, "height": 720}, on_request=requested.append) as page:
        page.get_by_role("alert").filter(has_text="seed").first.wait_for(timeout=20_000)
        found["trajectories, a refusal"] = violations(page)
        open_tab(page, "Compare σ")  # (each tab as it opens, in both modes: the test below)
        page.get_by_role("button", name="Compare", exact=True).click()
        page.get_by_role("img", name="Paper A's Fig. 3").wait_for(timeout=60_000)
        found["Compare σ, drawn"] = violations(page)
        open_tab(page, "Scenarios: σ(t), tails, sensor")
        page.get_by_role("button", name="Compute map").click()
        page.locator("td.cell").first.wait_for(timeout=120_000)
        found["Scenarios, the who-wins map drawn"] = violations(page)
        elsewhere = page.evaluate(SHEETS_ELSEWHERE, origin)
    assert {where: v for where, v in found.items() if v} == {}
    # and none of it asked another host for anything (the map's start asked the CDN for Panel's loading.css, a part
    # updated before it was shown for Panel's theme stylesheets)
    foreign = [u for u in requested if not u.startswith((origin, origin.replace("http", "ws", 1), "data:", "blob:"))]
    assert foreign == [], f"stylesheets of the page on another host (the class of the element they style): {elsewhere}"


#: the page's stylesheet links to another host than ``origin`` (through every shadow root): [the class of the element
#: whose shadow root holds the link (its bokeh model), URL], at most 10
SHEETS_ELSEWHERE = """(origin) => { const out = [];
    const look = (root, host) => { for (const link of root.querySelectorAll('link[rel=stylesheet]'))
        if (!link.href.startsWith(origin)) out.push([host, link.href]); };
    const walk = (root) => { for (const el of root.querySelectorAll('*')) if (el.shadowRoot) {
        look(el.shadowRoot, String(el.className).slice(0, 80)); walk(el.shadowRoot); } };
    look(document, 'document'); walk(document); return out.slice(0, 10); }"""


#: scrolls ``[k, sidebar]``: the window — and the sidebar, if ``sidebar`` — to their ``k``-th screen (the last one
#: flush with the end); false once each is past its end. axe measures the contrast of text in view only ("incomplete"
#: otherwise): the download buttons' 4.09 : 1 was seen only where they were in view at first.
SCROLL_TO = """([k, sidebar]) => { let more = false;
    const boxes = [document.scrollingElement, ...(sidebar ? [document.getElementById('sidebar')] : [])];
    for (const el of boxes) {
        const step = el.clientHeight - 80, end = el.scrollHeight - el.clientHeight;
        if (k === 0 || (k - 1) * step < end) { el.scrollTop = Math.min(k * step, end); more = true; }
    }
    return more; }"""


#: the rules whose outcome can depend on the window's size — what is in view (contrast, a link told apart in its text
#: block, a label's visibility), what overflows (scrollable regions), a table as wide as the window taken for layout:
#: the only ones run again when the same page is checked at another size (the others read the document, which the
#: size does not change)
SIZED_RULES = ["color-contrast", "scrollable-region-focusable", "link-in-text-block", "label", "th-has-data-cells"]


def scrolled_through(page, sidebar: bool, rules: list[str] | None = None) -> list:
    """axe's WCAG 2.1 AA violations at the top of the page (of ``rules`` only, if given), and its colour-contrast
    violations at each further screen of the window (and of the sidebar, if ``sidebar``), so that every control has
    been in view once."""
    found = violations(page, rules)
    k = 1
    while k < 15 and page.evaluate(SCROLL_TO, [k, sidebar]):
        page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")  # painted
        found += violations(page, ["color-contrast"])
        k += 1
    page.evaluate(SCROLL_TO, [0, sidebar])
    return found


#: text, canvases and images of the page that stand beyond the window's sides (through every shadow root; the folded
#: sidebar and the skip link are off screen on purpose): [tag, left, right, text]
OUTSIDE = """() => { const out = [];
    const walk = (root) => { for (const el of root.children) {
        if ((el.id === 'sidebar' && el.inert) || el.id === 'isl-skip') continue;
        if ((el.children.length === 0 && (el.textContent || '').trim()) || ['CANVAS', 'IMG'].includes(el.tagName)) {
            const r = el.getBoundingClientRect();
            if (r.width > 0 && r.height > 0 && (r.right > innerWidth + 1 || r.left < -1))
                out.push([el.tagName, Math.round(r.left), Math.round(r.right), (el.textContent || '').slice(0, 40)]);
        }
        walk(el);
        if (el.shadowRoot) walk(el.shadowRoot); } };
    walk(document); return out.slice(0, 5); }"""


TAB_TITLES = [
    "Trajectories (paper A, Fig. 3)",
    "ν sweep (paper A, Fig. 2)",
    "Worst case over σ",
    "Compare σ",
    "Scenarios: σ(t), tails, sensor",
    "Your data",
]


@pytest.mark.slow
@pytest.mark.parametrize("present", [False, True], ids=["normal", "presenter"])
def test_every_tab_meets_wcag_2_1_aa_and_fits_with_every_control_scrolled_into_view(app_server, present):
    """Every tab at 1280 × 720 (every rule) and 1920 × 1080 (the rules the size changes: :data:`SIZED_RULES`). The
    download buttons, grey #767676 on the sidebar's #f3f3f3 (4.09 : 1), were found only at 1920 × 1080, where they are
    in view at first: axe measures the contrast of text on screen only. And nothing stands beyond the window's sides
    (in presenter mode with the sidebar open the last tab's header read "Sc": that case is
    :func:`test_the_tab_headers_and_the_tables_long_notes_fit_the_window`)."""
    url, _ = app_server
    query = "?sc_runs=2&sc_horizon=8" + ("&present=1" if present else "")
    found, outside = {}, {}
    with dashboard(url + query, viewport={"width": 1280, "height": 720}) as page:
        for width, height in ((1280, 720), (1920, 1080)):
            page.set_viewport_size({"width": width, "height": height})
            for title in TAB_TITLES if width == 1280 else reversed(TAB_TITLES):  # (the open tab first)
                open_tab(page, title)
                # the sidebar is the same on every tab (and folded away in presenter mode)
                sidebar = not present and title == TAB_TITLES[0]
                rules = None if width == 1280 else SIZED_RULES  # every rule once per tab, at the first size
                found[f"{title}, {width} × {height}"] = scrolled_through(page, sidebar, rules)
                outside[f"{title}, {width} × {height}"] = page.evaluate(OUTSIDE)
    assert {where: v for where, v in found.items() if v} == {}
    assert {where: v for where, v in outside.items() if v} == {}


LOST_LOCK = "?alpha=0.01&beta_from_w=false&beta=1000&sigma=933&m=6&seed=2"  #: the table's long notes, X₁ up to 7.6e10


def test_the_tab_headers_and_the_tables_long_notes_fit_the_window(app_server):
    """The table's note "measured is 1.01e+04× it: the filter has lost lock, …" ran to x = 2320 in a 1920 window (now
    said once below the table); in
    presenter mode at 1280 × 720 with the sidebar open the last tab's header read "Sc" (BokehJS scrolls the headers
    sideways)."""
    url, _ = app_server
    with dashboard(url + LOST_LOCK, viewport={"width": 1920, "height": 1080}) as page:
        page.get_by_text("The filter has lost lock").first.wait_for(timeout=20_000)
        outside = {"1920 × 1080": page.evaluate(OUTSIDE)}
        page.set_viewport_size({"width": 1280, "height": 720})
        page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
        outside["1280 × 720"] = page.evaluate(OUTSIDE)
    with dashboard(url + "?present=1", viewport={"width": 1280, "height": 720}) as page:
        page.locator("#sidebar-button").click()
        page.wait_for_function("() => !document.getElementById('sidebar').inert", timeout=10_000)
        page.evaluate("() => new Promise(r => setTimeout(r, 400))")  # the sidebar's 0.3 s slide-in (Fast's CSS)
        outside["presenter mode, the sidebar open"] = page.evaluate(OUTSIDE)
        headers = page.evaluate("""() => { const t = Array.from(Bokeh.index.all_views()).find(v => v.header_els
            && v.model.type.endsWith('Tabs')); const box = t.el.getBoundingClientRect();
            return t.header_els.map(e => { const r = e.getBoundingClientRect();
                return [e.textContent, r.left >= box.left - 1 && r.right <= box.right + 1]; }); }""")
    assert {where: v for where, v in outside.items() if v} == {}
    assert [title for title, whole in headers if not whole] == [], headers


#: the focused element, through every shadow root: [tag, role, accessible label or text, outline, box-shadow, in view]
FOCUSED = """() => { let a = document.activeElement;
    while (a && a.shadowRoot && a.shadowRoot.activeElement) a = a.shadowRoot.activeElement;
    if (!a || a === document.body) return null;
    const cs = getComputedStyle(a), r = a.getBoundingClientRect();
    const label = a.getAttribute('aria-label') || (a.labels && a.labels[0] && a.labels[0].textContent)
        || a.getAttribute('title') || a.textContent || '';
    return [a.tagName, a.getAttribute('role'), label.trim().slice(0, 60), `${cs.outlineStyle} ${cs.outlineWidth}`,
            cs.boxShadow, r.bottom > 0 && r.right > 0 && r.top < innerHeight && r.left < innerWidth,
            a.getAttribute('aria-selected'), a.getAttribute('aria-valuetext')]; }"""


def focused(page) -> list:
    return page.evaluate(FOCUSED)


def test_the_page_can_be_operated_by_keyboard_alone(app_server):
    """The tabs ignored Enter, Space and the arrows (Space scrolled the page), reaching them took ≈ 57 Tab presses
    through the plots' toolbars, the focus on buttons was invisible and the sliders read their log position."""
    url, _ = app_server
    with dashboard(url, viewport={"width": 1280, "height": 720}) as page:
        page.keyboard.press("Tab")
        assert focused(page)[2] == "Skip to the views"
        page.keyboard.press("Enter")
        _, role, label, *_, selected, _ = focused(page)
        assert (role, label, selected) == ("tab", "Trajectories (paper A, Fig. 3)", "true")
        page.keyboard.press("ArrowRight")
        assert focused(page)[1:3] == ["tab", "ν sweep (paper A, Fig. 2)"]
        page.keyboard.press("Enter")
        page.wait_for_function("() => /tab=sweep/.test(location.search)", timeout=20_000)
        assert focused(page)[6] == "true"
        page.keyboard.press("Home")
        page.keyboard.press(" ")
        page.wait_for_function(f"() => ({TAB_OPEN})('Trajectories (paper A, Fig. 3)')", timeout=20_000)
        page.wait_for_function("() => !/tab=/.test(location.search)", timeout=20_000)  # the server has answered
        assert page.evaluate("scrollY") == 0  # Space opened the tab instead of scrolling the page
        # from the skip link on, up to the first plot's toolbar: every stop shows its focus ring and has a name, and
        # the tabs come before the toolbar (its buttons came before them)
        page.locator("#isl-skip").focus()
        stops = []
        while len(stops) < 80 and (not stops or stops[-1][2] != "Pan (x-axis)"):
            page.keyboard.press("Tab")
            stops.append(focused(page) or ["(nothing)", None, "", "", "", False, None, None])
    assert stops[-1][2] == "Pan (x-axis)", stops[-5:]
    rings = [s for s in stops if not (s[3].startswith("solid") and float(s[3].split()[1][:-2]) >= 2)]
    assert rings == [], rings
    unnamed = [s for s in stops if not s[2] and s[0] != "INPUT"]
    assert unnamed == [], unnamed
    assert [s[1] for s in stops].count("tab") == 1, [s[:3] for s in stops]  # one stop for the tab list


#: the focused element lies in the sidebar (through the shadow roots' hosts)
IN_SIDEBAR = """() => { let a = document.activeElement;
    while (a && a.shadowRoot && a.shadowRoot.activeElement) a = a.shadowRoot.activeElement;
    for (let n = a; n; n = n.parentNode || n.host) if (n.id === 'sidebar') return true;
    return false; }"""


def test_the_keyboard_reaches_no_folded_away_control_in_presenter_mode(app_server):
    """Presenter mode folds the sidebar away, yet Tab stops 6–36 landed on its controls (off screen, covered): the
    arrow keys then changed σ unseen. Unfolded, its controls are in the tab order again."""
    url, _ = app_server
    with dashboard(url + "?present=1", viewport={"width": 1280, "height": 720}) as page:
        page.locator("#isl-skip").focus()
        stops = []
        while len(stops) < 80 and (not stops or stops[-1][0][2] != "Pan (x-axis)"):
            page.keyboard.press("Tab")
            stops.append((focused(page) or ["(nothing)", None, ""], page.evaluate(IN_SIDEBAR)))
        assert stops[-1][0][2] == "Pan (x-axis)", [s[0][:3] for s in stops[-5:]]
        assert [s[0][:3] for s in stops if s[1]] == []
        assert page.locator("#sidebar-button").get_attribute("aria-expanded") == "false"
        page.locator("#sidebar-button").focus()
        page.keyboard.press("Enter")  # unfolds the sidebar
        page.wait_for_function("() => !document.getElementById('sidebar').inert", timeout=10_000)
        after = []
        while len(after) < 6 and not page.evaluate(IN_SIDEBAR):  # past the header's title, docs link and toggle
            page.keyboard.press("Tab")
            after.append(focused(page))
        assert page.evaluate(IN_SIDEBAR), after
        assert page.locator("#sidebar-button").get_attribute("aria-expanded") == "true"


def test_the_sliders_say_what_they_show_and_a_label_ticks_its_box(app_server):
    url, _ = app_server
    with dashboard(url, viewport={"width": 1280, "height": 900}) as page:
        sigma = page.get_by_role("slider", name="σ, observation noise intensity")
        assert sigma.get_attribute("aria-valuetext") == "20"  # not its position on the log scale, 1.30
        sigma.focus()
        for _ in range(10):
            sigma.press("ArrowRight")
        page.wait_for_function("() => /sigma=/.test(location.search)", timeout=20_000)
        text = sigma.get_attribute("aria-valuetext")
        shown = page.locator(".bk-slider-title", has_text="σ:").first.inner_text()
        assert text != "20" and shown.endswith(text), (text, shown)
        names = page.get_by_role("slider").evaluate_all("els => els.map(e => e.getAttribute('aria-label'))")
        assert len(names) >= 6 and all(names), names
        box = page.get_by_role("checkbox", name="KBF adaptive")
        assert not box.is_checked()
        page.get_by_text("KBF adaptive", exact=True).click()  # its label, not the box
        page.wait_for_function("() => /extra_filters=/.test(location.search)", timeout=20_000)
        assert box.is_checked()
