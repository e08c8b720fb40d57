"""The filters' colours, one palette for the dashboard's plots (:mod:`app.views.style`) and the exported figures
(:mod:`app.static_figures`); no plotting library is imported here."""
from __future__ import annotations

__all__ = ["EXTRA_COLORS", "ISL", "KBF", "TRUTH"]

TRUTH = "#000000"  #: X_i (paper A, Fig. 3: black)
KBF = "#1a9641"  #: Kalman–Bucy X̂_i and its ±3 s_i tube (green)
ISL = "#1f4fc1"  #: ISL X̌_i (blue)
EXTRA_COLORS = {  #: the baselines of app.extras: hues apart from truth, KBF, ISL and the σ colours of the sweep
    "kbf_mismatched": "#8c510a", "kbf_minimax": "#a50026", "kbf_adaptive": "#e6ab02", "isl_model": "#17becf",
}
