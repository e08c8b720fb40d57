"""The "Your data" tab in the browser: a CSV file uploaded, fitted, and the estimates BokehJS draws (its views' arrays)
equal to the core's (:func:`isl_core.series.judge`) for that file; a file with unsorted times refused beside the file
input, nothing fitted; a file over the limit refused by the browser before it is sent; nothing asked of another
host."""

from __future__ import annotations

import numpy as np
import pytest
from _browser import TAB_OPEN, dashboard
from test_browser_a11y import FOCUSED, violations

from isl_core.series import judge, read_csv

pytestmark = [pytest.mark.browser]


def _csv() -> bytes:
    """50 times, irregular: a slow wave and noise (small: the fit of six orders takes seconds)."""
    rng = np.random.default_rng(7)
    t = np.cumsum(rng.uniform(0.5, 1.5, 50))
    z = 10.0 * np.sin(t / 5.0) + rng.standard_normal(50)
    z[17] = np.nan  # one missing reading
    rows = "".join(f"{a:.6g},{'' if np.isnan(b) else f'{b:.6g}'}\n" for a, b in zip(t, z, strict=True))
    return ("# a recorded series\ntime,flow\n" + rows).encode()


#: per filter source of the plot: [name, x, y of its line, y1 and y2 of its band] as BokehJS's views hold them
DRAWN = """() => { const out = {};
    for (const v of Bokeh.index.all_views()) {
        if (v.model.type !== 'GlyphRenderer' || !/^data-/.test(v.model.data_source.name || '')) continue;
        const name = v.model.data_source.name.slice(5), g = v.glyph, o = out[name] || (out[name] = {});
        if (g.model.type === 'Line') { o.x = Array.from(g.x); o.y = Array.from(g.y); }
        if (g.model.type === 'VArea') { o.y1 = Array.from(g.y1); o.y2 = Array.from(g.y2); }
        if (g.model.type === 'Scatter') { o.x = Array.from(g.x); o.y = Array.from(g.y); }
    }
    return out; }"""


def test_an_uploaded_csv_is_drawn_as_the_core_fits_it_and_unsorted_times_are_refused(app_server):
    url, log = app_server
    data = _csv()
    j = judge(read_csv(data, name="mine.csv"), holdout=0.2)
    requested: list[str] = []
    ready = f"() => ({TAB_OPEN})('Your data')"
    with dashboard(url + "?tab=data&data_set=upload", ready=ready, on_request=requested.append) as page:
        page.locator("input[type=file]").set_input_files(
            files=[{"name": "mine.csv", "mimeType": "text/csv", "buffer": data}]
        )
        page.get_by_text("Fitted in").first.wait_for(timeout=180_000)
        page.wait_for_function("() => (" + DRAWN + ")()['kalman']?.y?.length > 0", timeout=20_000)
        drawn = page.evaluate(DRAWN)
        s = j.run.series
        np.testing.assert_array_equal(drawn["readings"]["x"], s.t)
        np.testing.assert_array_equal(np.array(drawn["readings"]["y"], dtype=float), s.z)  # NaN where missing
        for tr in j.run.tracks:
            got = drawn[tr.name]
            np.testing.assert_array_equal(got["x"], s.t)
            np.testing.assert_allclose(got["y"], tr.estimate[:, 0], rtol=1e-12, err_msg=tr.name)
            if tr.variance is not None:
                sd = np.sqrt(tr.variance[:, 0])
                np.testing.assert_allclose(got["y1"], tr.estimate[:, 0] - 3 * sd, rtol=1e-12, err_msg=tr.name)
                np.testing.assert_allclose(got["y2"], tr.estimate[:, 0] + 3 * sd, rtol=1e-12, err_msg=tr.name)
            else:  # no stated variance: no band drawn
                assert np.all(np.isnan(np.array(got["y1"], dtype=float))), tr.name
        # a file whose times go back: refused beside the file input, the fit on screen kept
        lines = data.decode().splitlines()
        lines[3], lines[4] = lines[4], lines[3]
        page.locator("input[type=file]").set_input_files(
            files=[{"name": "unsorted.csv", "mimeType": "text/csv", "buffer": "\n".join(lines).encode()}]
        )
        alert = page.get_by_role("alert").filter(has_text="times must increase strictly")
        alert.wait_for(timeout=60_000)
        assert "row 3" in alert.inner_text() and "Nothing was fitted" in alert.inner_text()
        assert page.evaluate(DRAWN)["kalman"]["y"] == drawn["kalman"]["y"]
        # a file over the limit is not even sent (the page's connection carries 20 MB a message): refused in words
        page.locator("input[type=file]").set_input_files(
            files=[{"name": "huge.csv", "mimeType": "text/csv", "buffer": b"1,2\n" * 4_000_000}]
        )
        page.get_by_role("alert").filter(has_text="huge.csv has 16,000,000 bytes, over the limit of 10 MB").wait_for(
            timeout=30_000
        )
        # the fitted tab, a refusal on screen: axe-core's WCAG 2.1 AA rules, and a keyboard walk from the data set's
        # box to the plot's toolbar — every stop named, with its focus ring
        assert violations(page) == []
        page.get_by_role("combobox", name="data set").focus()
        stops = []
        while len(stops) < 30 and (not stops or stops[-1][2] != "Pan"):
            page.keyboard.press("Tab")
            stops.append(page.evaluate(FOCUSED) or ["(nothing)", None, "", "", "", False, None, None])
    assert stops[-1][2] == "Pan", [s[:3] for s in stops]
    assert [s[:4] for s in stops if not (s[3].startswith("solid") and float(s[3].split()[1][:-2]) >= 2)] == []
    assert [s[:3] for s in stops if not s[2] and s[0] != "INPUT"] == []
    names = [s[2] for s in stops]
    assert any(n == "Fit" for n in names) and "Estimates (CSV)" in names, names
    assert "Traceback" not in log.read_text()
    # the file picker (a Panel custom component) and its module loader came from this server, nothing from another host
    origin = url.rsplit("/", 1)[0]
    assert [u for u in requested if not u.startswith((origin, origin.replace("http", "ws", 1), "data:", "blob:"))] == []
    assert any("es-module-shims" in u for u in requested), "the custom component's loader was not requested"
