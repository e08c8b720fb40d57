"""The "what am I looking at" text of the sidebar."""

from __future__ import annotations

import panel as pn

from isl_core import __version__
from isl_core.paper import PAPER_A, PAPER_B

from .style import TEXT_FONT

__all__ = ["ABOUT", "DOCS_LINK", "VERSION", "about_card", "docs_link"]

#: the version this server runs, as ``isl --version`` prints it (the one version string, isl_core.__version__)
VERSION = f"isl {__version__}"

#: the documentation this server serves at /docs/ (app.serving.docs); relative, so it stays under a proxy's prefix
DOCS_LINK = (
    '<a href="./docs/" target="_blank" rel="noopener" class="isl-docs-link" title="The documentation: the '
    'model and its equations, the filters, a guide to this page (opens in a new tab)">Docs</a>'
)

ABOUT = r"""
**The signal.** X₁ is a position, X₂ its velocity, X₃ its acceleration, … (m coordinates). The top
derivative Xₘ is an Ornstein–Uhlenbeck process, dXₘ = −α Xₘ dt + β dv: α is how fast it forgets (α = 0 makes
it a random walk, paper B), β how hard it is pushed. With **"β from w"**, β = w·√(2α) keeps the spread of Xₘ at w
whatever α (paper A's choice, w = 3). Only the position is observed, through white noise: dY = X₁ dt + σ dε.

**Two filters** estimate all m coordinates from Y:

* the **Kalman–Bucy filter** X̂ (green) is optimal — but it needs the noise intensity σ;
* the **ISL filter** X̌ (blue, *inverse statistical linearization*) does **not** know σ: it replaces the
  Kalman–Bucy gain by odd power laws of the innovation that match it for every σ. Its one knob is ν: a larger ν
  reacts faster (less lag behind a quickly moving signal) but passes more noise; the ν-sweep tab shows the
  trade-off, and "Use recommended ν" picks the ν whose worst ratio over the sweep's σ is smallest.

**The tube** X̂ᵢ ± 3 sᵢ (dashed green): sᵢ is the optimal filter's RMSE from theory (the Riccati equation),
so the true signal Xᵢ stays inside it about 99.7 % of the time; the table gives the measured share beside it.

**Time scale.** rₘᵢₙ is the slowest decay rate of the optimal filter's error (the smallest real part of its
closed-loop poles): after a few 1/rₘᵢₙ its error has forgotten where it started. The horizon is counted in
1/rₘᵢₙ — 10/rₘᵢₙ (paper A's Fig. 3) shows a few independent stretches of error; longer horizons tighten the
measured ratios. Every filter starts from the same random error drawn from the optimal filter's stationary
covariance Δ, so the optimal filter's ratio is ≈ 1 at any horizon.

**The numbers.** *Measured* figures come from this one simulated run (they scatter: raise the horizon to
tighten them); *theory* is computed from the equations, not simulated. A ratio š/s = 1.2 means the ISL filter's
RMSE is 20 % above the optimum's.

**Other filters** (tick them to overlay): the Kalman–Bucy filter designed for one σ used at another
(*mismatched*), the one designed for the largest σ of the range (*minimax*), an *adaptive* Kalman–Bucy filter
that estimates σ from its innovations, and a *model-aware* ISL filter (the same nonlinearity, with the
model's damping −αXₘ in its prediction).

**Who wins where, when every filter is tuned by the same rule** (the Scenarios tab; measured with `isl scenario` at
its defaults: α = 1, m = 3, w = 3, runs of 30/rₘᵢₙ, each filter's knob the one whose worst ratio over the table's
six scenarios is least on seeds 0–31, every ratio read on seeds 32–159 at the filter's worst coordinate):

* the **IMM** filter — a bank of Kalman filters over a grid of σ — wins or ties every cell, within 1.34 × the
  clairvoyant filter, and is about 2.5 × better than any other filter just after σ drops 100-fold;
* after such a drop, every other filter that learns σ, and both ISL filters, are 3–9 × the clairvoyant filter for a
  while;
* with constant but unknown σ in [2, 200], the ISL filter at its minimax ν is 2–2.5 × better than the best
  fixed-gain Kalman–Bucy filter, but a Kalman–Bucy filter that learns σ is at the optimum (`isl worstcase`);
* **the ISL filter wins no scenario** there. What it offers is cost and simplicity — a few tens of ns a step against
  hundreds for the learners and thousands for the IMM — and no model of σ at all: no σ range, no prior, no grid of
  σ, only ν.

The Scenarios tab runs this comparison for the page's model, with each filter's tuning and cost beside its ratios.

**The documentation** — the model and every equation, the filters, the scenarios and findings, a guide to this
page — is served with it: [Docs](./docs/) (also in the header).

**Equation numbers** such as (A.17) or (B.46) refer to the papers' equations:

* paper A — {a}
* paper B — {b}
"""


def about_card() -> pn.Card:
    """The card at the top of the sidebar, folded: its title is the first thing a newcomer reads there."""
    return pn.Card(
        pn.pane.Markdown(ABOUT.format(a=PAPER_A, b=PAPER_B), styles={"font-size": TEXT_FONT}),
        title="What am I looking at?",
        collapsed=True,
        sizing_mode="stretch_width",
        margin=(10, 5),
    )


def docs_link() -> pn.pane.HTML:
    """The header's link to the documentation served with the dashboard, after the version the server runs (white
    on the header's blue)."""
    return pn.pane.HTML(
        f'<span class="isl-version">{VERSION}</span> {DOCS_LINK}',
        margin=(18, 10),
        stylesheets=[
            ".isl-docs-link { color: #fff; font-size: 16px; font-weight: 600; }"
            ".isl-docs-link:hover, .isl-docs-link:focus { text-decoration: underline; }"
            ".isl-version { color: #fff; font-size: 14px; margin-right: 12px; }"
        ],
    )
