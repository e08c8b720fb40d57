"""Hostile input: ≥ 1000 generated bad values through the state class, and ≥ 1000 through raw document changes.

Bad values are generated from each input's declared bounds (nan, ±inf, None, strings, ±1e308, booleans,
values beyond either bound, containers, complex numbers, bytes, numpy scalars of the wrong kind …) with a
fixed seed. Every one must be answered with a message and leave the last good run in place; no exception may
escape and no answer may carry a traceback.

*State class*: :class:`app.state.AppState` in-process (jobs inline). *Raw document changes*: a scripted client
on the served dashboard sets widget model properties (slider ``value``/``value_throttled``, the seed spinner,
the checkboxes, the σ-list text box) to bad values through ``PATCH-DOC`` messages, bypassing every check of
the browser. An answer is a bokeh ``ERROR`` reply (the value does not fit the widget's type), a refusal in the
dashboard's status line, or a notification (a failed callback, via the global exception handler).
"""

from __future__ import annotations

import asyncio
import itertools
import math
from collections import Counter
from collections.abc import Iterator

import numpy as np
import param
import pytest
from _serving import run, served, session_client
from bokeh.models import Checkbox, ColumnDataSource, CustomJSTickFormatter, Slider, Spinner, TextInput

from app import extras
from app.state import ALL_INPUTS, DISPLAY_INPUTS, AppState, declaration
from app.state.sweep import SWEEP_SIGMA_BOUNDS

SEED = 20251122
MIN_VALUES = 1000
MIN_WIDGETS = 8  #: input widgets of the default page (sliders, spinners, check boxes, text inputs) at least
STRINGS = [
    "",
    " ",
    "abc",
    "1",
    "20",
    "nan",
    "inf",
    "1e3",
    "0x10",
    "σ",
    "\x00",
    "<script>alert(1)</script>",
    "DROP TABLE runs;",
    "1,2,3",
    "None",
    "True",
    "-1",
    "𝟙𝟚",
    "x" * 5000,
]
CONTAINERS = [[], [1.0], (2.0,), {"a": 1}, {1.0}, [[1.0]], range(3)]
ODDBALLS = [
    1 + 2j,
    b"1",
    bytearray(b"2"),
    object(),
    np.bool_(True),
    np.array([1.0, 2.0]),
    np.datetime64("2020-01-01"),
    Ellipsis,
    type,
    print,
]


def _beyond(lo: float, hi: float, rng: np.random.Generator, *, margin: float = 1e-6) -> float:
    """A finite value outside [lo, hi] by at least ``margin`` (relative), at a random scale.

    Below ``lo`` only if something finite lies below it (``lo`` = -inf: always above); a positive ``lo`` gets
    values in [0, lo).
    """
    if math.isfinite(lo) and rng.random() < 0.5:
        return (
            lo - max(abs(lo), 1.0) * 10.0 ** rng.uniform(math.log10(margin), 300)
            if lo <= 0
            else lo * rng.uniform(0.0, 1.0 - margin)
        )
    return hi + max(abs(hi), 1.0) * 10.0 ** rng.uniform(math.log10(margin), 300)


def _integral(value: float, lo: float) -> int:
    """``value`` as an int on the same side of the range (floor below ``lo``, ceil above), within ±(2**53 − 2)
    (larger integers lose precision in the browser; bokeh warns)."""
    if not math.isfinite(value):  # (_beyond's largest values overflow past a range that ends near 2**31)
        return int(math.copysign(2**53 - 2, value))
    n = math.floor(value) if value < lo else math.ceil(value)
    return int(min(max(n, -(2**53 - 2)), 2**53 - 2))


def bad_values(key: str, rng: np.random.Generator, n: int) -> Iterator[object]:
    """``n`` values that input ``key`` (in the session or one of its rooms) must refuse."""
    p = declaration(key)
    nonfinite = [math.nan, math.inf, -math.inf, 1e308, -1e308, np.float64("nan"), np.float32("inf"), None, True, False]
    if isinstance(p, param.Boolean):
        pool = [None, 0, 1, 1.0, "true", "False", math.nan, [], "yes", np.int64(1)]

        def picks():
            return pool[rng.integers(len(pool))]
    elif isinstance(p, param.ListSelector):
        names = list(p.objects)
        pool = [
            None,
            "nope",
            names[0],
            [names[0], "nope"],
            [1],
            [None],
            {names[0]: True},
            math.nan,
            ["<script>"],
            [names[0].upper()],
            3,
            [[names[0]]],
            [{}],
        ]

        def picks():
            return pool[rng.integers(len(pool))]
    elif isinstance(p, param.Selector):
        names = list(p.objects)
        pool = [None, "nope", 3, [names[0]], names[0].upper(), math.nan, {}, "", True, "<script>", f" {names[0]}"]

        def picks():
            return pool[rng.integers(len(pool))]
    elif isinstance(p, param.List):
        lo, hi = p.item_bounds  # of its entries

        def picks():
            k = rng.integers(6)
            if k == 0:
                return [float(rng.uniform(lo, hi)), math.nan][:: 1 if rng.random() < 0.5 else -1]
            if k == 1:
                return [float(rng.uniform(lo, hi)) for _ in range(p.bounds[1] + 1 + rng.integers(5))]
            if k == 2:
                return [_beyond(lo, hi, rng)]
            if k == 3:
                return [STRINGS[rng.integers(len(STRINGS))]]
            return [None, "2, 20, 200", 20.0, math.inf, True, {"a": 2.0}, []][rng.integers(7)]
    else:
        lo, hi = p.bounds
        integer = isinstance(p, param.Integer)

        def picks():
            k = rng.integers(6)
            if k == 0:
                return nonfinite[rng.integers(len(nonfinite))]
            if k == 1:
                value = _beyond(lo, hi, rng)
                return _integral(value, lo) if integer and rng.random() < 0.5 else value
            if k == 2:
                return STRINGS[rng.integers(len(STRINGS))]
            if k == 3:
                return CONTAINERS[rng.integers(len(CONTAINERS))]
            if k == 4 and integer:
                return float(rng.integers(lo, hi)) + 0.5  # fractional
            return ODDBALLS[rng.integers(len(ODDBALLS))]

    for _ in range(n):
        yield picks()


@pytest.fixture(scope="module")
def state() -> AppState:
    s = AppState()
    s.start()
    assert s.run is not None and s.message == ""
    return s


def test_state_refuses_every_bad_value_with_a_message_and_keeps_the_run(state):
    rng = np.random.default_rng(SEED)
    names = [k for k in ALL_INPUTS if k not in DISPLAY_INPUTS]  # every input of the model and of every room
    per_input = -(-MIN_VALUES // len(names)) + 5
    run0, traces0, values0 = state.run, state.traces, {n: state.get(n) for n in names}
    tried, answered, escaped = 0, 0, []
    for name in names:
        label = declaration(name).label
        for value in bad_values(name, rng, per_input):
            tried += 1
            state.message = ""
            try:
                state.set(name, value)
            except Exception as exc:  # noqa: BLE001  (the test counts what escapes)
                escaped.append((name, repr(value)[:60], repr(exc)[:200]))
                continue
            message = state.message
            if message.startswith("Refused: ") and label in message and "Traceback" not in message:
                answered += 1
            assert state.run is run0 and state.traces is traces0, (name, value)
            assert state.get(name) == values0[name], (name, value)
    print(f"state class: {tried} hostile values tried, {answered} answered with a message, {len(escaped)} escaped")
    assert tried >= MIN_VALUES
    assert escaped == []
    assert answered == tried
    state.sigma = 200.0  # still alive: a good value gives a new run
    assert state.run is not run0 and state.run.model.sigma == 200.0


def test_unhashable_filter_names_are_refused_with_a_message(state):
    run0 = state.run
    for value in ([[extras.EXTRA_NAMES[0]]], [{}]):
        state.message = ""
        state.set("extra_filters", value)
        assert "Refused" in state.message and state.run is run0


# -------------------------------------------------------------------------------- raw document changes
LABELS = {declaration(n).label: declaration(n) for n in ALL_INPUTS if n not in DISPLAY_INPUTS}


def widget_range(model) -> tuple[float, float]:
    """The widget values that map into the state's bounds: log10 of them for a log slider (its labels show
    10**value, :func:`app.views.controls.log_slider`), else the widget's own range."""
    p = LABELS.get(getattr(model, "title", None))
    if isinstance(model, Spinner):  # a box has no range of its own (the state refuses out-of-range values)
        lo, hi = p.bounds if p is not None else (model.low, model.high)
        return float(lo if lo is not None else 0), float(hi if hi is not None else 2**31 - 1)
    if p is not None and isinstance(getattr(model, "format", None), CustomJSTickFormatter):
        lo, hi = p.bounds
        return (math.log10(lo) if lo > 0 else -math.inf), math.log10(hi)
    return float(model.start), float(model.end)


def widget_bad_values(model, rng: np.random.Generator, n: int) -> list[dict]:
    """``n`` property patches for one widget model, none acceptable; consecutive accepted values never repeat."""
    if isinstance(model, Checkbox):
        pool = [None, 0, 1, "true", 2.5, math.nan, [], {"a": True}, "False", -1]
        return [{"active": pool[i % len(pool)]} for i in range(n)]
    if isinstance(model, TextInput):
        lo, hi = SWEEP_SIGMA_BOUNDS
        texts = itertools.cycle(
            [
                lambda: "",
                lambda: STRINGS[rng.integers(len(STRINGS))] + "x",
                lambda: f"{lo * rng.uniform(0.0, 0.9):.6g}",
                lambda: f"{hi * 10.0 ** rng.uniform(0.05, 300):.6g}",
                lambda: ", ".join(f"{rng.uniform(lo, hi):.4g}" for _ in range(6 + rng.integers(4))),
                lambda: f"{rng.uniform(lo, hi):.4g}, nan",
                lambda: f"inf, {rng.uniform(lo, hi):.4g}",
                lambda: None,
                lambda: 5.0,
                lambda: ["2", "20"],
            ]
        )
        return [{"value": next(texts)()} for _ in range(n)]
    lo, hi = widget_range(model)
    log = isinstance(getattr(model, "format", None), CustomJSTickFormatter)
    integer = isinstance(model, Spinner) or (not log and float(model.step) == 1.0)
    # log sliders round the state's value to 3 digits: stay ≥ 2 % (0.01 in log10) outside the range;
    # integer widgets truncate (Panel's IntSlider: int(value)): stay ≥ 1 outside, on distinct integers
    margin = 0.01 if log else 1.0 if integer else 1e-6
    last = [None]

    def beyond() -> float:
        while True:
            value = _beyond(lo, hi, rng, margin=margin)
            value = _integral(value, lo) if integer else value
            if value != last[0]:
                last[0] = value
                return value

    if isinstance(model, Spinner):
        # Panel's number boxes turn nan into None: put a fresh out-of-range number (an int for an integer box,
        # which Panel accepts) before each special value, so that every value the widget takes is a change
        specials = itertools.cycle([None, math.nan, math.inf, -math.inf, 1e308, -1e308])
        rejected = itertools.cycle(["abc", True, [1.0], {"v": 1}, "", False, "1e3"])
        picks = [beyond, lambda: next(specials), lambda: next(rejected)]
        return [{"value": picks[i % 3]()} for i in range(n)]

    # -inf and -1e308 map to 0 on a log slider: hostile only if 0 is outside the state's range
    low_extremes = [lambda: -math.inf, lambda: -1e308] if math.isfinite(lo) else [beyond, beyond]
    numeric = itertools.cycle(
        [
            lambda: math.nan,
            lambda: math.inf,
            beyond,
            low_extremes[0],
            beyond,
            lambda: 1e308,
            beyond,
            low_extremes[1],
            beyond,
        ]
    )
    typed = itertools.cycle([None, "abc", True, [1.0], {"v": 1}, "", False, "1e3"])
    out = []
    for i in range(n):
        value = next(typed) if i % 3 == 2 else next(numeric)()
        out.append({"value": value, "value_throttled": value} if isinstance(model, Slider) else {"value": value})
    return out


def refusals(doc) -> str:
    return "\n".join(t for t in session_client.markup_texts(doc) if "Refused" in t)


notifications = session_client.notifications


def plot_data(doc) -> dict:
    """Every ColumnDataSource's columns, as lists (what the plots show)."""
    return {
        m.id: {k: np.asarray(v).tolist() for k, v in m.data.items()}
        for m in doc.models
        if isinstance(m, ColumnDataSource)
    }


def loaded(doc) -> bool:
    """The page is complete: every input widget is there and the first run's plot data has arrived."""
    traj = doc.get_model_by_name("traj-1-isl")
    return traj is not None and len(traj.data.get("y", [])) > 0 and len(input_widgets(doc)) >= MIN_WIDGETS


async def quiet(client, seconds: float, limit: float = 60.0) -> None:
    """Wait until no patch has arrived for ``seconds``: after the barrage, the time any late answer had to land.
    (That nothing else arrives — no run started by a hostile value — is what the test checks: an absence, which
    no event can signal; the wait is bounded by ``limit``.)"""
    deadline = asyncio.get_running_loop().time() + limit
    while asyncio.get_running_loop().time() < deadline:
        count = len(client.patches)
        await asyncio.sleep(seconds)
        if len(client.patches) == count:
            return


async def push(client, model, attrs: dict, key: str) -> str | None:
    """Send one hostile patch; the kind of answer it got (None: no answer)."""
    doc = client.doc
    before_text, before_notes = refusals(doc), len(notifications(doc))
    msgid, _ = await client.change(model, **attrs)
    reply = await client.reply_to(msgid, 30)
    if reply is None:
        return None
    if reply.msgtype == "ERROR":
        assert reply.traceback is None and not any(m in reply.text for m in session_client.TRACEBACK_MARKERS)
        return "error reply"

    def answered() -> bool:
        return len(notifications(doc)) > before_notes or (refusals(doc) != before_text and "Refused" in refusals(doc))

    if await client.wait_until(answered, 10.0):
        return "notification" if len(notifications(doc)) > before_notes else "refused"
    return "refused (same text)" if f"Refused: {key} must be" in refusals(doc) else None


def bokeh_rejects(model, attrs: dict) -> bool:
    """Whether bokeh's own property validation refuses ``attrs`` on ``model`` (the server answers ``ERROR``)."""
    return not all(model.lookup(name).property.is_valid(value) for name, value in attrs.items())


async def pipelined_errors(client, pushes: list) -> tuple[Counter, list]:
    """Send every patch bokeh must refuse at once; each must get a traceback-free ``ERROR`` reply."""
    sent = [(await client.change(model, **attrs))[0] for model, attrs in pushes]
    replies = await asyncio.gather(*(client.reply_to(msgid, 120) for msgid in sent))
    kinds: Counter = Counter()
    bad = []
    for (model, attrs), reply in zip(pushes, replies, strict=True):
        if (
            reply is None
            or reply.msgtype != "ERROR"
            or reply.traceback is not None
            or any(m in reply.text for m in session_client.TRACEBACK_MARKERS)
        ):
            bad.append((type(model).__name__, repr(attrs)[:80], reply))
        else:
            kinds["error reply"] += 1
    return kinds, bad


async def sequential_answers(client, plan: dict, widgets: list) -> tuple[Counter, list]:
    """Send the patches bokeh accepts one by one, round robin over the widgets; collect the dashboard's answer."""
    kinds: Counter = Counter()
    unanswered = []
    for i in range(max(len(v) for v in plan.values())):
        for model in widgets:
            if i >= len(plan[model.id]):
                continue
            key = (getattr(model, "title", None) or getattr(model, "label", None) or "").split(" ")[0]
            attrs = plan[model.id][i]
            kind = await push(client, model, attrs, key)
            kinds[kind] += 1
            if kind is None:
                unanswered.append((type(model).__name__, key, repr(attrs)[:80]))
    return kinds, unanswered


def input_widgets(doc) -> list:
    found = [m for m in doc.models if isinstance(m, (Slider, Spinner, Checkbox, TextInput)) and m.visible]
    return sorted(found, key=lambda m: str(m.id))


@pytest.mark.slow
def test_raw_document_changes_are_refused_with_a_message(tmp_path):
    rng = np.random.default_rng(SEED + 1)
    with served(tmp_path, "--stats-interval", "0") as (url, proc, _):

        async def barrage():
            async with await session_client.BokehClient.connect(url, timeout=120) as client:
                assert await client.wait_until(lambda: loaded(client.doc), 120), "the page did not finish loading"
                doc = client.doc
                widgets = input_widgets(doc)
                per_widget = -(-MIN_VALUES // len(widgets))
                plan = {m.id: widget_bad_values(m, rng, per_widget) for m in widgets}
                before = plot_data(doc)
                rejected = [(m, a) for m in widgets for a in plan[m.id] if bokeh_rejects(m, a)]
                accepted = {m.id: [a for a in plan[m.id] if not bokeh_rejects(m, a)] for m in widgets}
                kinds, bad = await pipelined_errors(client, rejected)
                more, unanswered = await sequential_answers(client, accepted, widgets)
                await quiet(client, 1.0)
                texts = refusals(doc) + "\n".join(notifications(doc))
                return len(widgets), kinds + more, bad, unanswered, plot_data(doc) == before, texts, client.closed

        n_widgets, kinds, bad, unanswered, same_plots, texts, closed = run(barrage(), 900)
        alive = proc.poll() is None
    tried = sum(kinds.values()) + len(bad)
    print(f"raw document changes: {tried} hostile values on {n_widgets} widgets; answers: {dict(kinds)}")
    assert tried >= MIN_VALUES and n_widgets >= MIN_WIDGETS
    assert bad == [], bad[:5]
    assert same_plots, "a hostile value changed the plots: the last good run must stay"
    assert not closed and alive
    assert not any(m in texts for m in session_client.TRACEBACK_MARKERS)
    assert unanswered == [], unanswered[:10]
