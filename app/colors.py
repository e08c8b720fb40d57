"""The filters' colours, one palette for the dashboard's plots (:mod:`app.views.style`) and the exported figures
(:mod:`app.static_figures`); no plotting library is imported here."""

from __future__ import annotations

__all__ = ["EXTRA_COLORS", "ISL", "KBF", "TRUTH", "contrast", "difference", "text_on", "tint"]

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


def _lab(color: str) -> tuple[float, float, float]:
    """CIE L*a*b* (D65) of a ``#rrggbb`` colour (sRGB)."""
    rgb = [int(color[k : k + 2], 16) / 255.0 for k in (1, 3, 5)]
    r, g, b = (c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in rgb)
    xyz = (
        (0.4124 * r + 0.3576 * g + 0.1805 * b) / 0.95047,
        0.2126 * r + 0.7152 * g + 0.0722 * b,
        (0.0193 * r + 0.1192 * g + 0.9505 * b) / 1.08883,
    )
    fx, fy, fz = (t ** (1 / 3) if t > 216 / 24389 else (24389 / 27 * t + 16) / 116 for t in xyz)
    return 116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)


def difference(a: str, b: str) -> float:
    """How different two ``#rrggbb`` colours look: CIE76's ΔE, the distance of their L*a*b* (about 2.3 is just
    noticeable; two greens of 15.8 read as the same filter beside each other on a plot)."""
    return sum((p - q) ** 2 for p, q in zip(_lab(a), _lab(b), strict=True)) ** 0.5


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
