"""The filters' colours, one palette for the dashboard's plots (:mod:`app.views.style`) and the exported figures
(:mod:`app.static_figures`); no plotting library is imported here."""

from __future__ import annotations

__all__ = ["EXTRA_COLORS", "ISL", "KBF", "TRUTH", "contrast", "text_on", "tint"]

TRUTH = "#000000"  #: X_i (paper A, Fig. 3: black)
KBF = "#1a9641"  #: Kalman–Bucy X̂_i and its ±3 s_i tube (green)
ISL = "#1f4fc1"  #: ISL X̌_i (blue)
EXTRA_COLORS = {  #: the baselines of app.extras: hues apart from truth, KBF, ISL and the σ colours of the sweep
    "kbf_mismatched": "#8c510a",
    "kbf_minimax": "#a50026",
    "kbf_adaptive": "#e6ab02",
    "isl_model": "#17becf",
}


def _luminance(color: str) -> float:
    """WCAG 2.1's relative luminance of a ``#rrggbb`` colour."""
    rgb = [int(color[k : k + 2], 16) / 255.0 for k in (1, 3, 5)]
    lin = [c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in rgb]
    return 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2]


def contrast(a: str, b: str) -> float:
    """WCAG 2.1's contrast ratio of two ``#rrggbb`` colours (1 to 21; text needs 4.5 at level AA)."""
    la, lb = sorted((_luminance(a), _luminance(b)), reverse=True)
    return (la + 0.05) / (lb + 0.05)


def text_on(background: str) -> str:
    """Black or white, whichever reads better on ``background`` (at least 4.58 : 1 on any colour)."""
    return "#000000" if contrast("#000000", background) >= contrast("#ffffff", background) else "#ffffff"


def tint(color: str, share: float) -> str:
    """``color`` mixed with white: ``share`` of the colour, the rest white (a light shade of it)."""
    rgb = [int(color[k : k + 2], 16) for k in (1, 3, 5)]
    return "#" + "".join(f"{round(share * c + (1 - share) * 255):02x}" for c in rgb)
