"""Sidebar controls: presets, model and filter inputs, status and export — widgets bound to :class:`AppState`.

Scale parameters (α, w, β, σ, ν, horizon) get log-scale sliders: the widget moves over log10 of the
value, shows the value itself, and hands the state the value rounded to 3 significant digits (so links
read ``sigma=20``, not ``sigma=19.952623…``). A slider follows the mouse while it is dragged when the
current run is small (:attr:`AppState.live`), otherwise it applies on release (``value_throttled``).
"""

from __future__ import annotations

import math

import panel as pn
import param
from bokeh.models import CustomJSTickFormatter
from panel.viewable import Viewer

from ..presets import PAPER_PRESETS
from ..state import PARAMS, AppState
from ..text import num
from .fields import field, refusal
from .widgets import Guarded, IntSlider, NumberInput, Slider, WholeInput, resend, revert, same

__all__ = [
    "ControlsView",
    "Guarded",
    "IntSlider",
    "NumberInput",
    "Slider",
    "WholeInput",
    "log_slider",
    "round_sig",
    "with_help",
]

ALPHA_SLIDER_LOW = 0.01  #: the α slider's low end (its scale is log α; α = 0 is the box below it)
_LOG_FORMAT = "const v = Math.pow(10, tick); return Number(v.toPrecision(3)).toString();"


def round_sig(x: float, digits: int = 3) -> float:
    """``x`` rounded to ``digits`` significant digits."""
    return float(f"{x:.{digits - 1}e}")


class _Binding:
    """Two-way link between one widget and one state input, with a guard against echoes."""

    def __init__(self, state: AppState, name: str, widget, to_widget, to_state, *, live: bool = True) -> None:
        self.state, self.name, self.widget = state, name, widget
        self._to_widget, self._to_state = to_widget, to_state
        self._quiet = False
        self._moved = False  # the server moved the widget since the browser's last value
        events = ["value", "value_throttled"] if live and "value_throttled" in widget.param else ["value"]
        widget.param.watch(self._from_widget, events)
        if isinstance(widget, Guarded):  # a value the widget cannot take: the state refuses it, in words
            widget.refuse_with(self._refuse)
        state.watch(self._from_state, [name])
        self._from_state()

    def _refuse(self, raw) -> None:
        self.state.set(self.name, self._to_state(raw, force=True))
        if self.name in self.state.refusals:
            revert(self.state, self.widget, lambda: self._to_widget(self.state.get(self.name)))

    def _from_widget(self, *events) -> None:
        """Small runs follow ``value`` (while dragging); large ones only ``value_throttled`` (on release), or a
        ``value`` at the last release, which the browser does not send as a release again (:meth:`_released_again`).

        Only one of the two is used at a time: the throttled value lags behind the live one, and applying
        both would step the state back to an older position.
        """
        if self._quiet:
            return
        throttled = "value_throttled" in self.widget.param
        want = "value_throttled" if throttled and not self.state.live and not self._released_again(events) else "value"
        released = not throttled or any(e.name == "value_throttled" for e in events)
        if self._moved and released:  # the browser's value and the server's may have crossed: the browser then shows
            self._moved = False  # the older; sent again once the slider is let go (mid-drag, the handle jumped back)
            self.state.later(lambda: resend(self.widget))
        for event in events:
            if event.name != want:
                continue
            value = None if event.new is None else self._to_state(event.new)  # None from a box: it was emptied
            if event.new is not None and (value is None or same(value, self.state.get(self.name))):
                continue  # the state's own value (a revert's echo): not a change
            self.state.set(self.name, value)
            if self.name in self.state.refusals:  # refused: the widget shows the state's value again
                revert(self.state, self.widget, lambda: self._to_widget(self.state.get(self.name)))

    def _released_again(self, events) -> bool:
        """Whether ``events`` hold a value at the browser's last release, with no release of their own: once the server
        has moved the widget (a refused run taking its input back, a preset, a link), the browser keeps its last
        released value, and it sends only what its copy changes — a release at that same value comes as ``value``
        alone, and waiting for ``value_throttled`` would leave it unanswered. Taken as the release it is (a drag that
        only passes over that value starts a run the release then replaces)."""
        if any(e.name == "value_throttled" for e in events):
            return False
        last = self.widget.value_throttled
        return last is not None and any(e.name == "value" and same(e.new, last) for e in events)

    def _from_state(self, *events) -> None:
        value = self._to_widget(self.state.get(self.name))
        if value is None or value == self.widget.value:
            return  # the widget already shows it: sending it back would fight a slider being dragged
        self._quiet, self._moved = True, True
        try:
            self.widget.value = value
        finally:
            self._quiet = False


def log_slider(state: AppState, name: str, *, lo: float | None = None, step: float = 0.01) -> pn.widgets.FloatSlider:
    """A slider over log10 of input ``name`` across the input's bounds (from ``lo`` when its lower bound is 0, which
    a log scale cannot reach)."""
    p = PARAMS[name]
    a, b = math.log10(p.bounds[0] if lo is None else lo), math.log10(p.bounds[1])
    widget = Slider(
        label=p.label,
        start=a,
        end=b,
        step=step,
        format=CustomJSTickFormatter(code=_LOG_FORMAT),
        sizing_mode="stretch_width",
    )

    def to_widget(x: float) -> float | None:
        v = min(max(math.log10(x), a), b) if x > 0 else a
        return None if abs(v - widget.value) <= step / 2 else v

    def to_state(v: float, force: bool = False) -> float | None:
        if force:  # a value the slider cannot take (Guarded): the number it stands for, for the state to refuse
            return v if not math.isfinite(v) else (math.inf if v > 300 else 0.0 if v < -300 else 10.0**v)
        current = state.get(name)
        if current > 0 and abs(math.log10(current) - v) <= step / 2:
            return None  # the widget already shows the state's value: not a change
        return round_sig(10.0**v)

    _Binding(state, name, widget, to_widget, to_state)  # kept alive by the watchers it registers
    return widget


def with_help(widget, doc: str) -> pn.Row:
    """``widget`` with a (?) icon showing ``doc`` on hover."""
    return pn.Row(widget, pn.widgets.TooltipIcon(value=doc, margin=(22, 5, 0, 0)), sizing_mode="stretch_width")


def _plain(state: AppState, name: str, widget):
    _Binding(state, name, widget, lambda x: x, lambda v, force=False: v)
    return widget


class ControlsView(Viewer):
    """Presets, inputs (α, β/w, σ, ν, m, seed, horizon), the status line and the CSV download."""

    state = param.ClassSelector(class_=AppState)

    def __init__(self, **params) -> None:
        super().__init__(**params)
        s = self.state
        self._alpha = log_slider(s, "alpha", lo=ALPHA_SLIDER_LOW)
        self._alpha_zero = pn.widgets.Checkbox(label="α = 0 (white-noise derivative, paper B)")
        self._alpha_zero.param.watch(self._on_alpha_zero, "value")
        s.param.watch(self._sync_alpha_zero, ["alpha"])
        self._from_w = _plain(s, "beta_from_w", pn.widgets.Checkbox(label="β from w: β = w·√(2α) (paper A)"))
        self._w = log_slider(s, "w")
        self._beta = log_slider(s, "beta")
        self._sigma = log_slider(s, "sigma")
        self._nu = log_slider(s, "nu")
        m_lo, m_hi = s.param.m.bounds
        self._m = _plain(
            s, "m", IntSlider(label="m (state dimension)", start=m_lo, end=m_hi, sizing_mode="stretch_width")
        )
        # no range on the box: BokehJS's box drops a value outside it silently; the state refuses it in words
        self._seed = _plain(
            s, "seed", WholeInput(label="seed", width=120, description=s.param.seed.doc, value=float(s.seed))
        )
        self._horizon = log_slider(s, "horizon")
        self._sync_alpha_zero()
        self._derived = pn.pane.Markdown(self._derived_text, margin=(0, 10))
        self._status = pn.pane.Alert(
            self._status_text, alert_type=self._status_kind, visible=self._has_status, margin=(5, 10)
        )

    # ---- α = 0 -------------------------------------------------------------------------------------
    def _on_alpha_zero(self, event) -> None:
        if event.new and self.state.alpha != 0.0:
            self.state.alpha = 0.0
        elif not event.new and self.state.alpha == 0.0:
            self.state.alpha = self.state.alpha_before_zero

    def _sync_alpha_zero(self, *events) -> None:
        zero = self.state.alpha == 0.0
        self._alpha_zero.value = zero
        # at α = 0 the slider cannot show the value (its scale is log α): no number rather than its end, 0.01
        self._alpha.param.update(
            disabled=zero,
            show_value=not zero,
            name=f"{self.state.param.alpha.label} = 0 (ticked below)" if zero else self.state.param.alpha.label,
        )

    # ---- reactive text -----------------------------------------------------------------------------
    @param.depends("state.alpha", "state.beta_from_w", "state.w", "state.beta", "state.nu")
    def _derived_text(self) -> str:
        s = self.state
        beta = s.beta_effective
        if beta <= 0.0:
            return "β = w√(2α) = 0: untick **β from w** or raise α."
        return (
            f"β = **{num(beta)}** · ν/β = **{num(s.nu / beta, 3)}** (ℓ = log₂ ν/β = {num(math.log2(s.nu / beta), 3)})"
        )

    @param.depends("state.message")
    def _status_text(self) -> str:
        return self.state.message

    @param.depends("state.message_kind")
    def _status_kind(self) -> str:
        return self.state.message_kind

    @param.depends("state.message", "state.message_inline")
    def _has_status(self) -> bool:
        return bool(self.state.message) and not self.state.message_inline  # a refusal shows beside its input

    @param.depends("state.beta_from_w")
    def _beta_widget(self):
        return self._w if self.state.beta_from_w else self._beta

    def _preset_buttons(self) -> pn.Column:
        buttons = []
        for name, preset in PAPER_PRESETS.items():
            b = pn.widgets.Button(
                label=name,
                description=preset.description,
                color="primary",
                variant="outline",
                sizing_mode="stretch_width",
                margin=(2, 10),
            )
            b.on_click(lambda event, name=name: self.state.apply_preset(name))
            buttons.append(b)
        return pn.Column("### Presets", *buttons, sizing_mode="stretch_width")

    def __panel__(self):
        s = self.state
        new_seed = pn.widgets.Button(label="new noise", width=110, margin=(22, 10, 5, 5))
        new_seed.on_click(lambda event: setattr(s, "seed", (s.seed + 1) % (s.param.seed.bounds[1] + 1)))
        download = pn.widgets.FileDownload(
            callback=s.csv,
            filename="isl_run.csv",
            label="Download run (CSV)",
            color="success",
            variant="outline",
            sizing_mode="stretch_width",
            margin=(10, 10),
        )
        figure_png = pn.widgets.FileDownload(
            callback=s.png,
            filename="isl_figure.png",
            label="Download figure (PNG)",
            color="success",
            variant="outline",
            sizing_mode="stretch_width",
            margin=(0, 10, 10, 10),
        )
        spinner = pn.indicators.LoadingSpinner(value=s.param.busy, visible=s.param.busy, size=20, margin=(0, 10))

        def helped(name: str, widget):
            return field(s, name, with_help(widget, PARAMS[name].doc), sizing_mode="stretch_width")

        return pn.Column(
            self._status,
            self._preset_buttons(),
            pn.Row(pn.pane.Markdown("### Model", margin=(0, 10)), spinner),
            self._alpha_zero,
            helped("alpha", self._alpha),
            self._from_w,
            self._beta_widget,
            refusal(s, "w"),
            refusal(s, "beta"),
            helped("sigma", self._sigma),
            helped("m", self._m),
            pn.pane.Markdown("### ISL filter and run", margin=(0, 10)),
            helped("nu", self._nu),
            self._derived,
            helped("horizon", self._horizon),
            field(s, "seed", pn.Row(self._seed, new_seed)),
            download,
            figure_png,
            sizing_mode="stretch_width",
        )
