"""The "what am I looking at" text of the sidebar."""
from __future__ import annotations

import panel as pn

__all__ = ["ABOUT", "about_card"]

ABOUT = r"""
**The signal.** X₁ is a position, X₂ its velocity, X₃ its acceleration, … (m coordinates). The top
derivative X_m is an Ornstein–Uhlenbeck process, dX_m = −α X_m dt + β dv; α = 0 makes it a random walk
(paper B). Only the position is observed, through white noise: dY = X₁ dt + σ dε.

**Two filters** estimate all m coordinates from Y:

* the **Kalman–Bucy filter** X̂ (green) is optimal — but it needs the noise intensity σ;
* the **ISL filter** X̌ (blue, *inverse statistical linearization*) does **not** know σ: it replaces the
  Kalman–Bucy gain by odd power laws of the innovation that match it for every σ. Its one knob is ν.

**The tube** X̂ᵢ ± 3 sᵢ (dashed green): sᵢ is the optimal filter's RMSE from theory (the Riccati equation),
so the true signal Xᵢ stays inside it about 99.7 % of the time. The ISL estimate X̌ᵢ should stay close to
X̂ᵢ, well within the tube, if it is nearly as good as the optimum.

**The numbers.** *Measured* figures come from this one simulated run (they scatter: raise the horizon to
tighten them); *theory* is computed, not simulated. A ratio š/s = 1.2 means the ISL filter's RMSE is 20 %
above the optimum's. The **ν sweep** tab shows that ratio for all ν at once (paper A, Fig. 2).

Sources: Kuznetsov, Lebedev & Semenikhin (2025), *paper A*; Kuznetsov & Semenikhin (2025), *paper B*.
"""


def about_card() -> pn.Card:
    return pn.Card(pn.pane.Markdown(ABOUT, styles={"font-size": "14px"}), title="What am I looking at?",
                   collapsed=False, sizing_mode="stretch_width", margin=(10, 5))
