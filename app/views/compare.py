"""Compare view: the run on screen beside the same run at another σ — paper A's Fig. 3 (σ = 20 | σ = 200).

Both runs share every other input and the seed (the same driving noise v and ε; only σ scales the observation
noise), so the difference is σ's alone. The picture is drawn by the renderer of ``isl figure3`` and of the figure
download (:func:`app.static_figures.fig3_png`), both columns on one canvas with the parameters above each, and
the measured ratios of both runs are tabulated below it. Drawn on request ("Compare"), as one job on the pool of
large runs (off the event loop, below the slider runs' priority); a run on screen that changes afterwards marks
the picture as out of date instead of redrawing it at every slider move.
"""

from __future__ import annotations

import dataclasses
import html
import io

import panel as pn
import param
from panel.viewable import Viewer

from isl_core import BOUNDS

from .. import inputs
from ..pipeline import COORDINATES, Request, compute
from ..state import AppState
from ..text import R_MIN, per_r_min
from .fields import REFUSAL_CSS
from .numbers import TABLE_CSS
from .style import SUBSCRIPT, TEXT_FONT, px
from .widgets import NumberInput, revert, same

__all__ = ["CompareView", "alt_text", "compare_figure", "other_sigma"]


def other_sigma(sigma: float) -> float:
    """The σ to compare with by default: paper A's pair 20 | 200 (200 from anything below it, else 20)."""
    return 200.0 if sigma < 200.0 else 20.0


def compare_figure(shown, req: Request, sigma_b: float) -> tuple[bytes, list]:
    """The run on screen ``shown`` (simulated from ``req``) beside ``req`` at σ = ``sigma_b`` (same seed, same other
    inputs), drawn side by side as a PNG; and the two :class:`isl_core.runview.RunView` objects (for the table)."""
    from ..static_figures import fig3_png

    runs = [shown, compute(dataclasses.replace(req, sigma=sigma_b), nearest=True).run]
    out = io.BytesIO()
    fig3_png(runs, out, dpi=90, note="the same seed and inputs; only σ differs", font=1.35)
    return out.getvalue(), runs


def alt_text(runs) -> str:
    """What the comparison picture shows, for a screen reader (its numbers are in the table below it)."""
    m = runs[0].model.m
    sigmas = " and ".join(f"σ = {r.model.sigma:g}" for r in runs)
    return (
        f"Paper A's Fig. 3 for {sigmas}, side by side: for each of the {m} coordinates, the signal, the "
        "Kalman–Bucy estimate, the ISL estimate and the Kalman–Bucy estimate ± 3 sᵢ, against time; the measured "
        "RMSE ratios of both runs are in the table below the picture."
    )


def ratios_html(runs) -> str:
    """Measured RMSE ratios of both runs (KBF and ISL per coordinate), one column per run."""
    head = "".join(f"<th>σ = {r.model.sigma:g}<span class='tag'>KBF / ISL, measured</span></th>" for r in runs)
    rows = []
    for i in range(runs[0].model.m):
        k = str(i + 1).translate(SUBSCRIPT)
        cells = "".join(f"<td>{r.tracks[0].ratio[i]:.3f} / {r.tracks[1].ratio[i]:.3f}</td>" for r in runs)
        rows.append(f"<tr><td>X{k} {html.escape(COORDINATES[i])}</td>{cells}</tr>")
    return f"<table class='isl-numbers'><tr><th>RMSE / s<sub>i</sub></th>{head}</tr>{''.join(rows)}</table>"


class CompareView(Viewer):
    """The run on screen beside the same run at another σ (a tab of its own, built when first opened)."""

    state = param.ClassSelector(class_=AppState)
    sigma_b = inputs.Real(200.0, bounds=BOUNDS.sigma.range, label="σ of the second run")

    def __init__(self, **params) -> None:
        super().__init__(**params)
        self.param.update(sigma_b=other_sigma(self.state.sigma))
        self._image = pn.pane.PNG(None, sizing_mode="scale_width", max_width=1400, margin=(0, 10))
        self._table = pn.pane.HTML("", stylesheets=[TABLE_CSS], margin=(0, 10))
        self._note = pn.pane.Markdown("", margin=(0, 10))
        # a box without a range (BokehJS drops a value outside it silently), checked here and refused in words
        self._input = NumberInput(label=self.param.sigma_b.label, value=self.sigma_b, width=px(self.state, 180))
        self._input.refuse_with(self._take)
        self._input.param.watch(self._typed, "value")
        self._refusal = pn.pane.HTML("", visible=False, stylesheets=[REFUSAL_CSS], margin=(0, 10, 6, 10))
        self._button = pn.widgets.Button(
            label="Compare", color="primary", width=px(self.state, 130), margin=(24, 10, 0, 10)
        )
        self._button.on_click(lambda event: self.draw())
        self._drawn: Request | None = None
        self.state.param.watch(self._stale, ["run"])
        self._note.object = "Press **Compare** to draw the run on screen beside the same run at the σ above."

    def _typed(self, event) -> None:
        if not same(event.new, self.sigma_b):  # else the box shows σ of the second run again (after a refusal)
            self._take(event.new)

    def _take(self, value) -> None:
        """σ of the second run from the box, or its refusal beside the box (the previous σ is kept)."""
        p = self.param.sigma_b
        value = inputs.shape(p, value)
        try:
            self.param.update(sigma_b=value)
            self._refusal.param.update(object="", visible=False)
        except ValueError:
            text = html.escape(f"Refused: {inputs.refusal(p, value)}. The comparison keeps σ = {self.sigma_b:g}.")
            self._refusal.param.update(object=f"<div class='isl-refusal' role='alert'>{text}</div>", visible=True)
            revert(self.state, self._input, lambda: self.sigma_b)

    def draw(self) -> None:
        """Simulate the second run and draw both (a job; the picture replaces the last one when it is done)."""
        if self.state.run is None:
            self._note.object = "The comparison can be drawn once the first run is shown."
            return
        shown, self._drawn = self.state.run, self.state.shown_request
        self._note.object = f"Simulating σ = {self.sigma_b:g} beside the run on screen (σ = {shown.model.sigma:g}) …"
        self.state.submit(
            "compare", lambda req=self._drawn, b=self.sigma_b: compare_figure(shown, req, b), self._show, pool="large"
        )

    def _stale(self, *events) -> None:
        if self._drawn is not None and self._drawn != self.state.shown_request:
            self._note.object = "The run on screen has changed since this picture: press **Compare** to redraw it."

    def _show(self, outcome, superseded: bool) -> None:
        if superseded:
            return
        if outcome.error is not None:
            self._note.object = f"No comparison: {self.state.describe(outcome.error)}."
            return
        png, runs = outcome.value
        self._image.param.update(object=png, alt_text=alt_text(runs))
        self._table.object = ratios_html(runs)
        self._note.object = (
            f"Both runs: seed {runs[0].seed}, horizon {per_r_min(runs[0].horizon, 3)} of each "
            f"run's own {R_MIN}; computed in {outcome.seconds:.2g} s; drawn by the renderer of the "
            "command `isl figure3`."
        )

    def __panel__(self):
        intro = pn.pane.Markdown(
            "The run on screen beside the same run at another σ — paper A's Fig. 3 compares σ = 20 and σ = 200. "
            "Both use the same seed and every other input, so what changes is σ's doing.",
            margin=(0, 10),
            styles={"font-size": TEXT_FONT},
        )
        return pn.Column(
            intro,
            pn.Row(self._input, self._button),
            self._refusal,
            self._note,
            self._image,
            self._table,
            sizing_mode="stretch_width",
        )
