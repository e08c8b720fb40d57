"""What the browser draws is what the run says: read from BokehJS (its views' arrays, its legend labels), compared with
the core's numbers for the same inputs.

The tube X̂ᵢ ± 3 sᵢ after a preset and after a slider move, and to 1e-4 where X₁ is too large for float32; the
scenario legend after a scenario preset; the scenario plots' ranges, ticks and line patterns; presenter
mode at a projector's and a wall screen's size; the view and the open tab kept in the link and across presenter mode;
a link no parser can read; a refusal shown beside its input; the comparison picture's text alternative. The
accessibility checks of the same pages are in ``test_browser_a11y.py``.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from _browser import BAND_OFFSETS, DEEP, NAMED, PLOT_DATA, SCENARIO_TEXT, TAB_OPEN, dashboard, new_page

from isl_core import Model, kalman_bucy

pytestmark = [pytest.mark.browser]

#: true once every band's drawn offsets are the expected 3 sᵢ (``arg``: [name → 3 sᵢ, relative tolerance])
BANDS_ARE = f"""([want, tol]) => {{ const got = ({BAND_OFFSETS})();
    return got.length >= Object.keys(want).length && got.every(([name, n, a, b, c, d]) => !(name in want) || (n > 0
        && [a, b, c, d].every(x => Math.abs(x - want[name]) <= tol * want[name])));
}}"""


def three_s(alpha: float, w: float, sigma: float, m: int = 3) -> dict[str, float]:
    """3 sᵢ of the optimal filter (A.29), the tube's half-width, per plot's Kalman–Bucy source name."""
    s = np.sqrt(np.diag(kalman_bucy(Model.from_w(alpha, w, sigma, m)).delta))
    return {f"traj-{i + 1}-kbf": 3.0 * float(s[i]) for i in range(m)}


def wait_bands(page, want: dict[str, float], what: str, tol: float = 1e-4) -> None:
    from playwright.sync_api import Error as PlaywrightError  # its timeout and every other failure of the page

    try:
        page.wait_for_function(BANDS_ARE, arg=[want, tol], timeout=30_000)
    except PlaywrightError:
        raise AssertionError(
            f"{what}: the drawn tube is not X̂ ± 3 s of the run; drawn offsets "
            f"{page.evaluate(BAND_OFFSETS)}, 3 s = {want}"
        ) from None


def test_the_tube_follows_every_run_after_a_preset_and_a_slider_move(app_server):
    """After the preset "Fig. 3, σ = 200" the browser kept drawing σ = 20's half-widths (±50.4, ±23.2, ±8.87) around a
    run whose 3 sᵢ are 294, 47.9, 8.99: BokehJS did not recompute a band when only its offset changed."""
    url, _ = app_server
    with dashboard(url, viewport={"width": 1280, "height": 900}) as page:
        wait_bands(page, three_s(0.5, 3.0, 20.0), "the first run")
        page.get_by_role("button", name="Fig. 3, σ = 200").click()
        wait_bands(page, three_s(0.5, 3.0, 200.0), "after the preset σ = 200")
        handle = page.get_by_role("slider", name="σ, observation noise intensity")
        handle.focus()
        handle.press("Home")  # σ to its minimum, 0.1
        wait_bands(page, three_s(0.5, 3.0, 0.1), "after σ moved to its minimum")
        assert page.evaluate(
            "() => Array.from(Bokeh.index.all_views()).filter(v => v.model.type === 'Band').every(v => v.model.visible)"
        )


def test_the_tube_is_three_s_to_1e_4_where_x1_is_too_large_for_float32(app_server):
    """At m = 6, β = 1000 (|X₁| up to 7.6e10) BokehJS computed the tube's edges in float32: half-widths of 4096–8192
    around a 3 s₁ of 5526.6."""
    url, _ = app_server
    s = np.sqrt(np.diag(kalman_bucy(Model(0.01, 1000.0, 933.0, 6)).delta))
    want = {f"traj-{i + 1}-kbf": 3.0 * float(s[i]) for i in range(6)}
    with dashboard(url + "?alpha=0.01&beta_from_w=false&beta=1000&sigma=933&m=6&seed=2") as page:
        wait_bands(page, want, "m = 6, β = 1000", tol=1e-4)


def test_the_tube_follows_new_noise_after_the_error_view_moved_it_to_another_source(app_server):
    """Found by the random actions of ``test_browser_property.py``: BokehJS listens to the source a band had when it
    was first drawn. X₄'s plot, first drawn in the error view (its band on the zero line), then switched to the signal
    (the band moved to X̂₄), kept the old noise's band around the new X̂₄ after "new noise": same 3 s₄, so no offset
    changed."""
    url, _ = app_server
    with dashboard(url + "?view=errors", viewport={"width": 1280, "height": 900}) as page:
        wait_bands(page, {k.replace("-kbf", "-truth"): v for k, v in three_s(0.5, 3.0, 20.0).items()}, "errors")
        handle = page.get_by_role("slider", name="m, state dimension")
        handle.focus()
        handle.press("ArrowRight")  # m = 4: X₄'s plot is drawn for the first time, in the error view
        wait_bands(page, {k.replace("-kbf", "-truth"): v for k, v in three_s(0.5, 3.0, 20.0, 4).items()}, "m = 4")
        page.get_by_role("button", name="Signal and estimates", exact=True).click()
        wait_bands(page, three_s(0.5, 3.0, 20.0, 4), "the signal view")
        before = page.evaluate(PLOT_DATA)
        page.get_by_role("button", name="new noise", exact=True).click()
        page.wait_for_function(
            f"(before) => {{ const now = ({PLOT_DATA})(); return now && now !== before; }}", arg=before, timeout=30_000
        )
        wait_bands(page, three_s(0.5, 3.0, 20.0, 4), "after new noise")


def test_the_scenario_legend_names_the_run_shown_after_a_preset(app_server):
    """The legend said "Kalman–Bucy for constant σ = σ(0) = 20" and "ISL (ν = 3)" after the preset σ 200 → 2 had set
    σ(0) = 200 and ν = 0.849: it was labelled once, at its first draw. The time axis read "1/r  min"."""
    from app.state.scenarios import PRESETS

    url, _ = app_server
    label = next(k for k in PRESETS if "200 → 2" in k)
    nu = PRESETS[label]["nu"]
    with dashboard(
        url + "?tab=scenarios&sc_runs=2&sc_horizon=12",
        viewport={"width": 1280, "height": 900},
        ready=f"() => ({TAB_OPEN})('Scenarios: σ(t), tails, sensor')",
    ) as page:
        page.wait_for_function(
            f"() => ({SCENARIO_TEXT})().some(f => f[1].some(t => t.includes('σ(0) = 20')))", timeout=60_000
        )
        page.get_by_label("scenario preset (the table's columns)").select_option(label=label)
        want = ["Kalman–Bucy for constant σ = σ(0) = 200", f"ISL (ν = {nu:.4g})"]
        page.wait_for_function(
            f"(want) => want.every(w => ({SCENARIO_TEXT})().some(f => f[1].includes(w)))", arg=want, timeout=60_000
        )
        texts = page.evaluate(SCENARIO_TEXT)
    labels = [t for f in texts for t in f[1]]
    assert not any("σ(0) = 20 " in t or t.endswith("σ(0) = 20") for t in labels), labels
    axes = [a for f in texts for a in f[2] if a]
    assert axes and all("r_min" not in a and "rₘᵢₙ" in a for a in axes), axes


NUMBERS_BOX = f"""() => {{ const t = ({DEEP})('table.isl-numbers.ratios'); if (!t) return null;
    const r = t.getBoundingClientRect(); return [r.left, r.right, r.width]; }}"""


@pytest.mark.parametrize("size", [(1280, 720), (1920, 1080)], ids=["1280x720", "1920x1080"])
def test_presenter_mode_fits_the_screen_and_enlarges_the_plots_text(app_server, size):
    """Presenter mode scrolled sideways (the main area 1325 px wide in a 1280 window) and cut off the "Xᵢ in tube"
    column; its legends and ticks kept their desk size."""
    url, _ = app_server
    width, height = size
    with dashboard(url + "?present=1", viewport={"width": width, "height": height}) as page:
        page.wait_for_function(f"() => ({NUMBERS_BOX})() !== null", timeout=20_000)
        assert page.evaluate("document.documentElement.scrollWidth") <= width
        left, right, table_width = page.evaluate(NUMBERS_BOX)
        sizes = page.evaluate("""() => Array.from(Bokeh.index.all_views()).filter(v => v.model.type === 'Legend'
            || v.model.type === 'LinearAxis').map(v => v.model.type === 'Legend' ? v.model.label_text_font_size
            : v.model.major_label_text_font_size)""")
    assert left >= 0 and right <= width + 0.5 and table_width > 300, (left, right, table_width)
    points = [float(s.removesuffix("pt")) for s in sizes]
    assert points and min(points) >= 14.0, sizes  # 11 pt at a desk, ×19/14 for a projector


def test_the_view_and_the_tab_stay_in_the_link_and_across_presenter_mode(app_server):
    url, _ = app_server
    with dashboard(url, viewport={"width": 1600, "height": 1000}) as page:
        page.get_by_text("Errors (estimate − signal)", exact=True).click()
        page.get_by_role("tab", name="Worst case over σ").click()
        page.wait_for_function(
            "() => /view=errors/.test(location.search) && /tab=worstcase/.test(location.search)", timeout=20_000
        )
        page.get_by_role("button", name="Presenter mode").click()
        page.wait_for_function("() => /present=1/.test(location.search)", timeout=20_000)
        page.get_by_role("button", name="Leave presenter mode").wait_for(timeout=30_000)
        page.get_by_role("tab", name="Worst case over σ", selected=True).wait_for(timeout=30_000)
        page.get_by_role("tab", name="Trajectories (paper A, Fig. 3)").click()
        page.wait_for_function(
            f"""() => [1, 2, 3].every(i => {{ const s = ({NAMED})(`traj-${{i}}-truth`);
            return s && s.data.y.length === 2; }})""",
            timeout=30_000,
        )  # the error view: the signal is the zero line
    assert "view=errors" in page.url


def test_a_link_with_a_5000_digit_seed_opens_the_page_and_refuses_the_value(app_server):
    """Panel's own query parser converted the digits to an int, over Python's 4300-digit limit, before the page's
    parser ran: the page stayed blank."""
    url, log = app_server
    with dashboard(url + "?sigma=50&seed=" + "7" * 5000) as page:
        refusal = page.get_by_role("alert").filter(has_text="seed")
        refusal.first.wait_for(timeout=20_000)
        text = refusal.first.inner_text()
        table = page.locator("table.isl-numbers.ratios").inner_text()
    assert "seed" in text and "whole number from 0 to 2147483647" in text and "5,000 characters" in text
    assert "X₁ position" in table
    assert "Traceback" not in log.read_text() and "4300" not in log.read_text()


def _refusal_below(page, box_locator, text: str) -> dict:
    """The live region saying ``text`` and its distance below ``box_locator``'s widget (px)."""
    alert = page.get_by_role("alert").filter(has_text=text).first
    alert.wait_for(timeout=20_000)
    box, below = box_locator.bounding_box(), alert.bounding_box()
    return {"text": alert.inner_text(), "gap": below["y"] - (box["y"] + box["height"]), "x": below["x"] - box["x"]}


def test_a_refusal_is_shown_beside_the_input_that_caused_it(app_server):
    """The seed box took −5 with no message in sight; the ν sweep's "2, abc" was refused at the top of the sidebar,
    scrolled away from the box. Each refusal now sits under its input, in a live region a screen reader reads."""
    url, _ = app_server
    with dashboard(url, viewport={"width": 1280, "height": 900}) as page:
        seed = page.get_by_label("seed", exact=True)
        seed.fill("-5")
        seed.press("Enter")
        near = _refusal_below(page, seed, "seed must be a whole number from 0 to 2147483647")
        assert 0 <= near["gap"] < 80 and "-5 is below that range" in near["text"], near
        page.get_by_role("tab", name="ν sweep (paper A, Fig. 2)").click()
        sigmas = page.get_by_label("σ values (comma separated)")
        sigmas.wait_for(timeout=30_000)
        sigmas.fill("2, abc")
        sigmas.press("Enter")
        near = _refusal_below(page, sigmas, "σ values")
        assert 0 <= near["gap"] < 80 and '"abc" is not a number' in near["text"], near
        seed.fill("4")
        seed.press("Enter")
        page.get_by_role("alert").filter(has_text="seed must be").wait_for(state="detached", timeout=20_000)


def test_the_comparison_picture_has_a_text_alternative(app_server):
    url, _ = app_server
    with dashboard(
        url + "?tab=compare", viewport={"width": 1280, "height": 900}, ready=f"() => ({TAB_OPEN})('Compare σ')"
    ) as page:
        page.get_by_role("button", name="Compare", exact=True).click()
        image = page.get_by_role("img", name="Paper A's Fig. 3 for σ = 20 and σ = 200")
        image.wait_for(timeout=60_000)
        alt = image.get_attribute("alt")
        natural = image.evaluate("img => img.naturalWidth")
    assert "table below" in alt and natural > 900


@pytest.mark.parametrize(
    ("lo", "hi", "px", "expected"),
    [
        (0.9, 12.0, 400, [1, 1.2, 1.5, 2, 3, 5, 10, 12]),  # a ν-sweep row: the minimum ≈ 1.1 can be read off
        (1.0, 1.3, 400, [1, 1.05, 1.1, 1.2, 1.3]),  # worst cases of 1.06 and 1.23 apart
        (1.0, 1.3, 60, [1, 1.2]),  # the same range drawn small: no two labels touch
        (1.0, 1e6, 400, [1, 10, 100, 1000, 1e4, 1e5, 1e6]),  # many decades: powers of ten
        (0.5, 0.5, 400, []),  # an empty range: no ticks rather than an error
    ],
)
def test_ratio_axes_tick_the_first_digits_and_never_overlap(lo, hi, px, expected):
    """The log ratio axes (app.views.style.ratio_ticker) tick 1, 1.2, 1.5, 2, …, and no finer than the plot's
    height lets labels stand apart (1.1 and 1.2 overlapped on a short ν-sweep plot): the ticker's own JavaScript,
    run in chromium on the ranges and heights those charts show."""
    from app.views.style import TICK_GAP, ratio_ticker

    ticker = ratio_ticker()
    args = {**ticker.args, "plot": {"inner_height": px}}
    with new_page() as page:
        ticks = page.evaluate(
            "([code, args, cb_data]) => new Function('cb_data', ...Object.keys(args), code)"
            "(cb_data, ...Object.values(args))",
            [ticker.major_code, args, {"start": lo, "end": hi}],
        )
    assert ticks == pytest.approx(expected)
    gaps = [px * math.log(b / a) / math.log(hi / lo) for a, b in itertools.pairwise(ticks)]
    assert all(g >= TICK_GAP for g in gaps), gaps


def test_the_first_open_of_a_tab_says_it_is_being_built(app_server):
    """The ν-sweep tab was blank for ≈ 2.6 s at its first opening; now a progress line shows until it is built."""
    url, _ = app_server
    with dashboard(url, viewport={"width": 1280, "height": 900}) as page:
        page.get_by_role("tab", name="ν sweep (paper A, Fig. 2)").click()
        page.get_by_text("Building “ν sweep (paper A, Fig. 2)” …").wait_for(timeout=10_000)
        page.get_by_role("button", name="Simulate points").wait_for(timeout=60_000)
        assert page.evaluate(PLOT_DATA)  # the trajectories are still there, in their own tab


#: per scenario plot as BokehJS holds it: [title, y start, y end, least and greatest positive value of its source's
#: columns, its y ticks, the frame's top (window px) and height, the y label's width as drawn, its lines' colour and
#: dash]
SCENARIO_PLOTS = """() => Array.from(Bokeh.index.all_views()).filter(v => v.model.type === 'Figure' && v.model.title
        && /clairvoyant|σ\\(t\\)/.test(v.model.title.text)).map(v => {
    const axis = Array.from(Bokeh.index.all_views()).find(a => a.model.type === 'LogAxis' && a.parent === v);
    const m = axis.model, ctx = document.createElement('canvas').getContext('2d');
    ctx.font = `${m.axis_label_text_font_style} ${m.axis_label_text_font_size} ${m.axis_label_text_font}`;
    let lo = Infinity, hi = -Infinity;
    for (const [k, col] of Object.entries(v.model.renderers[0].data_source.data)) if (k !== 't')
        for (const x of col) if (isFinite(x) && x > 0) { lo = Math.min(lo, x); hi = Math.max(hi, x); }
    const lines = v.model.renderers.filter(r => r.glyph.type === 'Line')
        .map(r => [JSON.stringify(r.glyph.line_color), JSON.stringify(r.glyph.line_dash)]);
    return [v.model.title.text, v.model.y_range.start, v.model.y_range.end, lo, hi,
        Array.from(axis.tick_coords.major[1]), v.el.getBoundingClientRect().top + v.frame.bbox.top,
        v.frame.bbox.height, ctx.measureText(m.axis_label).width, lines]; })"""


def test_the_scenario_plots_hold_their_bands_and_tell_filters_apart_in_presenter_mode(app_server):
    """The ratio axis ended at 4.07 while the 95 % bands reached 4.59; the σ(t) axis labelled 15 and 20 on top of
    each other; the constant-σ Kalman–Bucy line and the IMM's were both green and every line was solid; in presenter
    mode at 1280 × 720 the first screen held only inputs and the y label was cut ("…(worst coordinat")."""
    from app.views.style import PRESENTER_SCALE, TICK_GAP

    url, _ = app_server
    with dashboard(
        url + "?tab=scenarios&present=1&sc_runs=3&sc_horizon=20",
        viewport={"width": 1280, "height": 720},
        ready=f"""() => {{ const s = ({NAMED})('scenario-ratio'); const f = ({SCENARIO_TEXT})();
            return s && s.data.t.length > 0 && f.length === 2 && f.every(p => p[1].length > 1); }}""",
    ) as page:
        page.wait_for_function(f"() => ({SCENARIO_PLOTS})().every(p => p[7] > 0)", timeout=20_000)  # laid out
        plots = page.evaluate(SCENARIO_PLOTS)
        page.wait_for_function(f"() => ({DEEP})('p.isl-key') !== null", timeout=20_000)  # the period table's caption
        table, caption = page.evaluate(
            f"() => [({DEEP})('table.isl-scn').textContent, ({DEEP})('p.isl-key').textContent]"
        )
    # the default model's filters at the shipped tuning's knobs, no row untuned
    assert "untuned" not in table and "tuned: W = " in table, table
    assert "Knobs: shipped tuning, tuned at α = 0.5, m = 3 (grid at m = 3" in caption, caption
    (_, start, end, lo, hi, _, top, height, *_), sigma = plots
    assert start <= lo and end >= hi, (start, end, lo, hi)  # the lines and their bands, all in view
    assert top + height / 2 <= 720, (top, height)  # at least half the ratio plot on the first screen
    for name, *_, frame, label, lines in plots:
        assert label <= frame, (name, label, frame)  # the y label is whole
        assert len({c for c, _ in lines}) == len(lines) and len({d for _, d in lines}) == len(lines), (name, lines)
    ticks, frame, (s_lo, s_hi) = sigma[5], sigma[7], sigma[1:3]
    gaps = [frame * math.log(b / a) / math.log(s_hi / s_lo) for a, b in itertools.pairwise(ticks)]
    assert len(ticks) >= 2 and min(gaps) >= TICK_GAP * PRESENTER_SCALE - 1, (ticks, gaps)


#: [the lookup is skipped, the tube's colour as BokehJS paints it, the page's CSS rules (every stylesheet,
#: shadow roots included) that set a --bk-* variable — BokehJS's canvas theming]
UNTHEMED = """() => {
    const proto = Bokeh.require("core/visuals/visual").VisualProperties.prototype;
    const band = Array.from(Bokeh.index.all_views()).find(v => v.model.type === 'Band'
        && v.model.source.name === 'traj-1-kbf');
    const sheets = [], walk = (root) => { sheets.push(...(root.styleSheets || []), ...(root.adoptedStyleSheets || []));
        for (const el of root.querySelectorAll('*')) if (el.shadowRoot) walk(el.shadowRoot); };
    walk(document);
    const themed = [];
    for (const sheet of sheets) { let rules = []; try { rules = Array.from(sheet.cssRules); } catch (e) {}
        for (const r of rules) if (/--bk-[\\w-]+\\s*:/.test(r.cssText)) themed.push(r.cssText.slice(0, 80)); }
    return [proto._get_css_value.__isl_unthemed === true, band.visuals.line.get_line_color(), themed]; }"""


def test_the_canvas_takes_its_colours_from_the_models_without_css_lookups(app_server):
    """BokehJS looked up a --bk-* CSS variable for every visual property at every paint, about 1000 a slider change,
    each forcing the style recalculation pending after the change (the axes' paint 17.8 → 5.7 ms a change): the page
    defines none of them, so the lookups are skipped (app.views.paint). Fails if BokehJS renames the method, or if a
    stylesheet of the page starts theming the canvas."""
    from app.colors import KBF

    url, _ = app_server
    with dashboard(url) as page:
        skipped, color, themed = page.evaluate(UNTHEMED)
    assert skipped, "the page did not install app.views.paint.UNTHEMED_CANVAS"
    assert color == KBF and themed == []
