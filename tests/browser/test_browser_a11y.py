"""A page anyone can operate (WCAG 2.1 AA): axe-core's rules on every view of the page, and a keyboard-only walk.

axe-core (pinned in ``tests/js/package-lock.json``, installed by ``./scripts/test``) is injected into the served page
and run with the WCAG 2.0/2.1 A and AA rules on each state a class sees: the trajectories at a projector's size, each
tab opened, presenter mode, refusals on screen, the who-wins map and the comparison picture drawn. Canvas content is
beyond axe: the plots' text is checked by what BokehJS holds (``test_browser_truth.py``) and the map's colours by
their computed contrast (``test_app_scenario.py``). The walk uses the keyboard alone: the skip link, the tabs (arrow
keys, Enter, Space), a visible focus ring at every stop, sliders that say what they show.
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


def violations(page) -> list:
    """axe-core's WCAG 2.1 AA violations of ``page`` (axe injected once per page)."""
    assert AXE.exists(), f"axe-core is not installed at {AXE}: run ./scripts/test"
    if not page.evaluate("() => typeof window.axe === 'object'"):
        page.add_script_tag(path=str(AXE))
    return page.evaluate(AXE_RUN, WCAG_AA)


def open_tab(page, title: str) -> None:
    page.get_by_role("tab", name=title).click()
    page.wait_for_function(f"() => ({TAB_OPEN})({title!r})", timeout=60_000)


def test_every_view_of_the_page_meets_wcag_2_1_aa(app_server):
    """Before: sliders without a name, checkboxes without labels, unnamed spinner buttons, a template list holding
    divs, white on green buttons at 2.5 : 1, code at 2.3 : 1, the map's white on cyan or yellow at 2.1 : 1."""
    url, _ = app_server
    found = {}
    requested: list[str] = []
    query = "?seed=-5&sc_runs=2&sc_horizon=8&sc_map=tails&sc_map_seeds=2"  # a refusal on screen from the start
    with dashboard(url + query, viewport={"width": 1280, "height": 720}, on_request=requested.append) as page:
        page.get_by_role("alert").filter(has_text="seed").first.wait_for(timeout=20_000)
        found["trajectories, a refusal"] = violations(page)
        for title in ("ν sweep (paper A, Fig. 2)", "Worst case over σ"):
            open_tab(page, title)
            found[title] = violations(page)
        open_tab(page, "Compare σ")
        page.get_by_role("button", name="Compare", exact=True).click()
        page.get_by_role("img", name="Paper A's Fig. 3").wait_for(timeout=60_000)
        found["Compare σ, drawn"] = violations(page)
        open_tab(page, "Scenarios: σ(t), tails, sensor")
        page.get_by_role("button", name="Compute map").click()
        page.locator("td.cell").first.wait_for(timeout=120_000)
        found["Scenarios, the who-wins map drawn"] = violations(page)
    with dashboard(url + "?present=1", viewport={"width": 1280, "height": 720}, on_request=requested.append) as page:
        found["presenter mode"] = violations(page)
    assert {where: v for where, v in found.items() if v} == {}
    # and none of it asked another host for anything (the map's start asked the CDN for Panel's loading.css)
    origin = url.rsplit("/", 1)[0]
    assert [u for u in requested if not u.startswith((origin, origin.replace("http", "ws", 1), "data:", "blob:"))] == []


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
