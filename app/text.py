"""How the page writes the quantities it names: r_min, times in units of 1/r_min, plain numbers.

The page says what it shows in words and symbols a student reads, never in the code's names: ``r_min`` is written
rₘᵢₙ on the plots' canvas (Unicode subscripts: a canvas has no markup) and r<sub>min</sub> in HTML; a number is
written plainly, never in a program's exponent notation ("1000/rₘᵢₙ", not "1e+03/r_min").
"""

from __future__ import annotations

import math
import re

__all__ = ["R_MIN", "R_MIN_HTML", "num", "per_r_min", "per_r_min_html", "powers"]

R_MIN = "rₘᵢₙ"  #: the optimal filter's settling rate, as text (the plots' titles and labels, Markdown)
R_MIN_HTML = "r<sub>min</sub>"  #: the same in HTML


def num(x: float, digits: int = 4) -> str:
    """``x`` with ``digits`` significant digits, written plainly from 10⁻⁶ to 10⁷ (as the sliders show it, without
    thousands separators), else as ``a × 10^k``."""
    x = float(x)
    if not math.isfinite(x):
        return "∞" if x > 0 else ("−∞" if x < 0 else "not a number")
    if x == 0.0:
        return "0"
    if 1e-6 <= abs(x) < 1e7:
        exponent = math.floor(math.log10(abs(x)))
        decimals = max(digits - 1 - exponent, 0)
        text = f"{round(x, decimals):.{decimals}f}"
        if "." in text:
            text = text.rstrip("0").rstrip(".")
        return text.replace("-", "−")
    mantissa, power = f"{x:.{digits - 1}e}".split("e")
    mantissa = mantissa.rstrip("0").rstrip(".")
    return f"{mantissa} × 10^{int(power)}".replace("-", "−")


def per_r_min(x: float, digits: int = 4) -> str:
    """A time in units of 1/r_min: ``"10/rₘᵢₙ"``."""
    return f"{num(x, digits)}/{R_MIN}"


def per_r_min_html(x: float, digits: int = 4) -> str:
    """The same in HTML: ``"10/r<sub>min</sub>"``."""
    return f"{num(x, digits)}/{R_MIN_HTML}"


_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def powers(text: str) -> str:
    """``2^-4`` written 2⁻⁴ (a whole exponent in superscript), ``2^-4.5`` written 2^(−4.5)."""

    def sup(match: re.Match) -> str:
        e = match.group(2)
        return match.group(1) + (e.translate(_SUPERSCRIPT) if "." not in e else f"^({e.replace('-', '−')})")

    return re.sub(r"(\d)\^(-?\d+(?:\.\d+)?)", sup, text)
