"""The isl dashboard's page: assembles state and views (served by ``app/app.py``).

This is a module, imported once per process: the server runs the script ``app/app.py`` anew for every session (a
fresh module namespace each time), so whatever must exist once — the long-job queue, the page's design class, the
extension set-up — lives here. (When it lived in the script, each session made its own long-job queue: its thread
kept the session's whole namespace alive after the session closed, and two sessions' long jobs ran at once.)

:func:`create_app` builds a fresh, independent page per browser session: its own :class:`AppState`, with
the parameters read from (and written back to) the URL, compute on the shared thread pools of
:mod:`app.jobs`, and the session's results released when it closes. Outside a server session (scripts,
tests) jobs run inline.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, ClassVar

import panel as pn
from bokeh.document import Document
from panel.io.resources import CDN_DIST
from panel.viewable import Viewable
from threadpoolctl import threadpool_limits

from app.jobs import LARGE_POOL, RUN_POOL, VIEW_POOL, Jobs, LongJobQueue
from app.serving.session import (
    building_page,
    handle_exception,
    page_location,
    prebuild,
    release_on_destroy,
    session_lock,
)
from app.state import TABS, AppState
from app.urlsync import UrlSync, after_pause, follow_history
from app.views import ControlsView, NumbersView, SweepView, TrajectoriesView, a11y, about_card
from app.views.about import docs_link
from app.views.compare import CompareView
from app.views.data import DataView
from app.views.filters_panel import FiltersPanel
from app.views.paint import skip_same_stylesheet
from app.views.scenario import ScenarioView
from app.views.style import text_scale
from app.views.worstcase import WorstCaseView

__all__ = ["LONG_JOBS", "TAB_TITLES", "TITLE", "LocalFast", "SessionGate", "create_app", "deferred", "session_jobs"]

TITLE = "Kalman–Bucy vs the ISL filter: filtering with unknown noise intensity"
ACCENT = "#1f4fc1"  #: the header's and the widgets' accent colour (white text on it: 7.3 : 1)
#: the tabs' titles, in the order of :data:`app.state.TABS`
TAB_TITLES = {
    "trajectories": "Trajectories (paper A, Fig. 3)",
    "sweep": "ν sweep (paper A, Fig. 2)",
    "worstcase": "Worst case over σ",
    "compare": "Compare σ",
    "scenarios": "Scenarios: σ(t), tails, sensor",
    "data": "Your data",
}
PAGE_CSS = a11y.PAGE_CSS
#: the tab headers wrap onto a second row where one row is too narrow (BokehJS scrolls them sideways, out of sight:
#: in presenter mode with the sidebar open, at 1280 px, the last tab read "Sc")
TABS_CSS = ":host(.bk-above) .bk-headers-wrapper { flex-wrap: wrap; overflow: visible; }"

#: the server's one queue of long jobs (sweeps, recommendations, worst cases): every session's, one at a time, each
#: in a child process (see app.jobs.long for the measurements behind that choice)
LONG_JOBS = LongJobQueue(workers=1, max_waiting=8, processes=True)

# The model's matrices are m×m (m ≤ 6): multithreaded BLAS only adds overhead, and its spinning threads slow the
# other sessions' jobs (:ref:`performance-warm-up`).
threadpool_limits(limits=1, user_api="blas")
# an error in a callback: its traceback to the server's log, a notice with an incident id to the user
pn.extension(notifications=True, exception_handler=handle_exception)


class SessionGate:
    """``schedule(fn)``: run ``fn`` on ``doc``'s event loop with its lock held (callable from any thread) — but only
    once the browser has the page.

    Panel drops the changes made to a document before its session counts as connected, because the document is
    "serialized in full once the session connects"; yet the browser may already have pulled it. A job that
    finishes in that window (a session's first run, computed while the page loads) would then be lost: the page
    kept showing "Simulating the first run …" (seen under CPU load). So outcomes wait here until Panel's
    ``onload`` for the session has run, then go to the loop in order.
    """

    def __init__(self, doc) -> None:
        self.doc = doc
        self._open = False
        self._pending: list[Callable[[], None]] = []
        self._lock = threading.Lock()

    def schedule(self, fn: Callable[[], None]) -> None:
        with self._lock:
            if not self._open:
                self._pending.append(fn)
                return
        self._execute(fn)

    def opened(self) -> None:
        """The page is connected (Panel's onload): apply what waited, and everything from now on at once."""
        with self._lock:
            self._open = True
            pending, self._pending = self._pending, []
        for fn in pending:
            self._execute(fn)

    def apply_here(self) -> None:
        """On the thread building the page (before the browser can have it): apply the outcomes that arrived
        meanwhile right here, so that the page goes out with them — usually the first run, computed while the page
        was built — instead of re-walking every model of the page on the event loop later
        (:ref:`performance-page-building`)."""
        from panel.io.state import set_curdoc

        with self._lock:
            if self._open:
                return
            pending, self._pending = self._pending, []
        with set_curdoc(self.doc):
            for fn in pending:
                fn()

    def _execute(self, fn: Callable[[], None]) -> None:
        from panel.io.state import set_curdoc

        doc = self.doc
        # bokeh's one-shot callback and its wrapper hold each other (a reference cycle) and hold ``run``: ``run``
        # lets go of ``fn`` — and with it the outcome, a whole run's traces — once it has run, else they would stay
        # until a full garbage collection, which a class rarely gets (:ref:`performance-memory-release`)
        held = [fn]

        def run() -> None:
            # every model change of one outcome goes out in one message; and Panel must see the session's
            # document while the views update: without it Panel rebuilds each pane's stylesheet models on each
            # update, and new models make the server re-walk every model of the page (:ref:`performance-page-building`).
            # The session's lock: a browser event of this page may be being processed on a thread right now
            # (app.serving.hardening.serialize_session_events); it holds the lock only while its callback runs.
            if not held:
                return
            apply = held.pop()
            with session_lock(doc), set_curdoc(doc), pn.io.hold(doc):
                apply()

        with set_curdoc(doc):
            pn.state.execute(run, schedule=True)


def session_jobs(gate: SessionGate | None = None) -> Jobs:
    """Thread-pool jobs bound to the current server session (their outcomes through ``gate``, by default a new
    one), or inline jobs outside a server."""
    doc = pn.state.curdoc
    if doc is None or doc.session_context is None:
        return Jobs()
    pools = {"run": RUN_POOL, "large": LARGE_POOL, "theory": RUN_POOL, "view": VIEW_POOL}
    if gate is None:
        gate = SessionGate(doc)
    pn.state.onload(gate.opened)
    return Jobs(pools, schedule=gate.schedule, long_queue=LONG_JOBS)


class LocalFast(pn.theme.Fast):
    """Panel's Fast design without its web font (Open Sans from fonts.googleapis.com).

    Every other file of the page is served by the dashboard's own server; the font alone came from the internet.
    The design also gives every component the page's own stylesheet, ``app/theme.css`` (focus ring, contrast).
    On a classroom network without internet access that request fails, and behind a firewall that drops it the
    stylesheet (in the page's head) can hold the first paint until the browser gives up. Text uses the system
    sans-serif instead (the font never loaded where the request failed, so the page looks the same there).
    """

    _resources: ClassVar[dict[str, Any]] = {
        **{kind: res for kind, res in pn.theme.Fast._resources.items() if kind != "font"},
        # Panel names a design's own files after the class ("localfast/..."): point at the Fast design's file
        "js_modules": {
            **pn.theme.Fast._resources["js_modules"],
            "fast-design": f"{CDN_DIST}bundled/fast/js/fast_design.js",
        },
    }
    #: every component also gets the page's own rules (``theme.css``: the focus ring, text colours at 4.5 : 1)
    modifiers: ClassVar[dict[Any, dict[str, Any]]] = {
        **pn.theme.Fast.modifiers,
        Viewable: {"stylesheets": [*pn.theme.Fast.modifiers[Viewable]["stylesheets"], "theme.css"]},
    }

    def params(self, viewable: Viewable, doc: Document | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
        """Panel's parameters of the design for ``viewable`` in ``doc``, with the stylesheets of the session's
        document where Panel names no document.

        Panel updates a markup pane (HTML, Markdown, Alert) with the stylesheets of its model's document. A model
        outside the page has none — a part whose models are built before it is swapped in
        (:func:`app.serving.session.prebuild`), a hidden tab's content — and Panel then made the theme's stylesheets
        (``default.css``, ``fast.css``) anew on its CDN, which the part carried into the page once shown. The
        session's document (Panel's ``curdoc`` wherever the page is built or updated) holds them already pointed at
        the server's files (:func:`app.serving.session.serve_panel_files`)."""
        return super().params(viewable, doc if doc is not None else pn.state.curdoc)


def deferred(build: Callable[[], object], shown: bool = True):
    """``build()``'s result: built with the page when the server builds pages on its page thread
    (:class:`app.serving.offloop.OffLoopApplication`) and the part is ``shown`` at once; otherwise built after the
    page is connected — on Panel's thread pool when the server has one (``--num-threads``), never while the session
    is being created on the event loop.

    A part swapped into a connected page costs the event loop a walk of every model of the page (bokeh's
    ``recompute``), the serialization of the part's models and Panel's search of the page for links; built with the
    page instead (off the loop, one walk), the browser pulls the whole page at once. The hidden tabs' parts
    (``shown=False``) are still deferred: most pages never open them. Their models are built on the thread too
    (:func:`app.serving.session.prebuild`), not on the loop when the part is swapped in. Measurements:
    :ref:`performance-page-building`.
    """
    if shown and building_page():
        return pn.panel(build())

    def built():
        obj = pn.panel(build())
        prebuild(obj, pane._inner_layout)
        return obj

    # a least height, so that the loading indicator Panel lays over the part while it is built can be seen (at
    # 0 px a tab opened for the first time stayed blank for seconds)
    pane = pn.panel(built, defer_load=True, loading_indicator=True, sizing_mode="stretch_width", min_height=320)
    return pane


def create_app(state: AppState | None = None) -> pn.template.FastListTemplate:
    """A new dashboard page over ``state`` (a fresh :class:`AppState` by default), URL-synced when served."""
    doc = pn.state.curdoc
    gate = SessionGate(doc) if state is None and doc is not None and doc.session_context is not None else None
    if state is None:
        state = AppState(jobs=session_jobs(gate))
    location = page_location(doc)  # (the page's URL; given to the template by app/app.py)
    if location is not None:
        UrlSync(state, location, after_pause(pn.state.curdoc))  # kept alive by the watchers it registers
        follow_history(pn.state.curdoc)
    state.start()
    release_on_destroy(state.close)
    skip_same_stylesheet(pn.state.curdoc)
    basis = round(620 * text_scale(state))  # the plots' least width beside the numbers (wider text: wider plots)
    trajectories = deferred(
        lambda: pn.FlexBox(  # the numbers beside the plots where both fit, else below them
            pn.Column(
                TrajectoriesView(state=state),
                styles={"flex": f"1 1 {basis}px", "min-width": "0"},
                sizing_mode="stretch_width",
            ),
            NumbersView(state=state),
            flex_wrap="wrap",
            align_items="flex-start",
            sizing_mode="stretch_width",
        )
    )
    # (the numbers' column is as wide as its table at the page's font size: 430 px, or more in presenter mode)
    present = state.present
    views = {
        "trajectories": trajectories,
        "sweep": on_first_open(state, "sweep", lambda: SweepView(state=state)),
        "worstcase": on_first_open(state, "worstcase", lambda: WorstCaseView(state=state)),
        "compare": on_first_open(state, "compare", lambda: CompareView(state=state)),
        "scenarios": on_first_open(state, "scenarios", lambda: ScenarioView(state=state)),
        "data": on_first_open(state, "data", lambda: DataView(state=state)),
    }
    tabs = pn.Tabs(
        *((TAB_TITLES[name], views[name]) for name in TABS),
        active=TABS.index(state.tab),
        sizing_mode="stretch_width",
        dynamic=True,
        stylesheets=[TABS_CSS],
    )  # a hidden tab is not built until it is opened
    _link_tabs(tabs, state)
    page = pn.template.FastListTemplate(
        title=TITLE,
        sidebar=[
            deferred(about_card),
            deferred(lambda: ControlsView(state=state)),
            deferred(lambda: FiltersPanel(state=state)),
        ],
        main=[tabs],
        sidebar_width=340,
        accent_base_color=ACCENT,
        header_background=ACCENT,
        theme_toggle=False,
        main_layout=None,
        busy_indicator=None,
        design=LocalFast,
        font="sans-serif",
        header=[docs_link(), presenter_toggle(present)],
        collapsed_sidebar=present,
        raw_css=[PAGE_CSS, *([PRESENTER_CSS] if present else [])],
    )
    a11y.install(pn.state.curdoc)
    if gate is not None and building_page():
        gate.apply_here()
    return page


#: presenter mode: larger text everywhere (the plots' own fonts are already sized for a projector)
PRESENTER_CSS = """
:root, body { font-size: 19px; --type-ramp-base-font-size: 19px; --isl-table-font: 18px; --isl-text-font: 19px;
              --isl-note-font: 17px; --isl-tag-font: 15px; }
.bk-root, .bk-panel-models-markup-HTML, .markdown { font-size: 19px; }
"""

#: the toggle's script: the same page with ``present=1`` added to (or removed from) its URL — every input is in the
#: URL already, so the page comes back with the same run
_TOGGLE_JS = """
const url = new URL(window.location.href);
const on = ['1', 'true', 'on', 'yes'].includes((url.searchParams.get('present') || '').trim().toLowerCase());
if (on) url.searchParams.delete('present'); else url.searchParams.set('present', '1');
try { sessionStorage.setItem('isl-focus', 'presenter'); } catch (e) {}  // the reloaded page focuses the toggle again
window.location.href = url.toString();
"""


def on_first_open(state: AppState, name: str, build: Callable[[], object]):
    """The part shown in tab ``name``: built with the page when the page opens on that tab, else when the tab is first
    opened — on a worker thread, its bokeh models too (:func:`app.serving.session.prebuild`), then swapped in on the
    session's loop. Meanwhile the tab says what is happening (built by Panel as the tab opened, the part would be sent
    only once whole, the tab blank until then: :ref:`performance-page-building`)."""
    if state.tab == name:
        return deferred(build)
    holder = pn.Column(
        pn.Row(
            pn.indicators.LoadingSpinner(value=True, size=28, margin=(4, 10)),
            pn.pane.Markdown(f"**Building “{TAB_TITLES[name]}” …**", margin=(6, 0)),
            margin=(20, 10),
        ),
        sizing_mode="stretch_width",
    )
    started = threading.Event()
    doc = pn.state.curdoc

    def build_part():
        # as the session's document: built without it, Panel pointed the part's stylesheets at its CDN (the page then
        # asked cdn.holoviz.org for loading.css when the part's progress bar first showed)
        from bokeh.io.doc import patch_curdoc
        from panel.io.state import set_curdoc

        with set_curdoc(doc), patch_curdoc(doc):
            part = pn.panel(build())
            prebuild(part, holder)
        return part

    def show(outcome, superseded: bool) -> None:
        holder.objects = [
            outcome.value
            if outcome.error is None
            else pn.pane.Alert(f"This view could not be built: {state.describe(outcome.error)}.", alert_type="danger")
        ]

    def opened(*events) -> None:
        if state.tab == name and not started.is_set():
            started.set()
            # from the loop, after the tab switch Panel has scheduled there (the tabs' models re-walked with the
            # page's): the part's build then does not compete with that walk for the interpreter
            state.later(lambda: state.submit(f"tab:{name}", build_part, show, pool="view"))

    state.param.watch(opened, "tab", precedence=1)  # after the tabs follow the state (_link_tabs: precedence 0)
    return holder


def _link_tabs(tabs: pn.Tabs, state: AppState) -> None:
    """The open tab and the state's ``tab`` input follow each other (so the link and presenter mode keep it)."""

    def from_tabs(event) -> None:
        if TABS[event.new] != state.tab:
            state.tab = TABS[event.new]

    def from_state(event) -> None:
        if tabs.active != TABS.index(event.new):
            tabs.active = TABS.index(event.new)

    tabs.param.watch(from_tabs, "active")
    state.param.watch(from_state, "tab")


def presenter_toggle(present: bool) -> pn.widgets.Button:
    """The header's one toggle of presenter mode, kept in the URL (``present=1``)."""
    button = pn.widgets.Button(
        label="Leave presenter mode" if present else "Presenter mode",
        color="light",
        variant="outline",
        width=240,
        margin=(12, 10),
        description="Larger text and the controls folded away, for a projector; the setting stays in the link",
    )
    button.js_on_click(code=_TOGGLE_JS)
    return button
