"""The observation noise's laws on the Euler grid and their tables (:ref:`noise-laws`, :mod:`isl_core.scenario`); the
compiled loops draw them (:mod:`isl_core.kernels.draws`).

``law`` is an int for the loops: :data:`LAW_GAUSSIAN` ε_k ~ N(0, 1); :data:`LAW_STUDENT` √((d − 2)/d)·T_d, Student's t
with d > 2 degrees of freedom scaled to unit variance; :data:`LAW_OUTLIERS` N(0, 1), times k with probability p.
From the caller's ``numpy.random.Generator``, per ε_k: one normal (Gaussian); one uniform, rarely more (Student-t,
below); one normal (outliers), and one uniform per outlier (the steps between two outliers are geometric: one
uniform a step, deciding each step, would cost the scenario loop a draw at every step: :ref:`performance-scenario`).

Student's t is drawn by a ziggurat (G. Marsaglia & W. W. Tsang, "The ziggurat method for generating random
variables", J. Stat. Softw. 5(8), 2000) built for d by :func:`student_table`: 256 layers of equal area under
f(x) = (1 + x²/d)^{−(d+1)/2} (the base layer with the tail beyond r), so that one uniform — 8 bits for the layer, one
for the sign, 44 for the position in the layer — gives T_d in ≈ 98 % of draws. The rest fall in a layer's wedge
(accepted when a second uniform under the layer's height is under f) or, below 0.2 %, in the tail beyond r, drawn
from a Pareto envelope tangent to f in log–log coordinates (log f is concave in log x: the tangent is above it),
accepted with f/envelope. Exact but for the 2⁻⁴⁴ grid of positions in a layer, for every d from 2 + 10⁻⁹ to 10⁶.
Why a ziggurat: one uniform a draw costs about what a normal costs, several times less than NumPy's ``standard_t`` (a
normal over the root of a gamma draw) or Bailey's polar method (R. W. Bailey, Math. Comp. 62, 1994: pairs of uniforms
in the disc, a log and an exp a draw), so heavy-tailed noise costs a scenario run hardly more than Gaussian noise
(the figures: :ref:`performance-scenario`).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

__all__ = ["LAWS", "LAW_GAUSSIAN", "LAW_OUTLIERS", "LAW_STUDENT", "LAYERS", "law_table", "student_table"]

LAW_GAUSSIAN, LAW_STUDENT, LAW_OUTLIERS = 0, 1, 2
LAWS = {"gaussian": LAW_GAUSSIAN, "student": LAW_STUDENT, "outliers": LAW_OUTLIERS}  #: by :attr:`Scenario.noise`
LAYERS = 256  #: of the Student-t ziggurat


def _f(x: float, d: float) -> float:
    return math.exp(-(d + 1.0) / 2.0 * math.log1p(x * x / d))


def _climb(r: float, d: float) -> tuple[float | None, float, list[float], list[float]]:
    """The layers' edges X (decreasing from r) and heights Y = f(X) for a base edge r, and how far the last layer's
    top overshoots f(0) = 1 (> 0: r is too small; None when a layer already passed 1)."""
    from scipy import special, stats  # here, not at import: only a Student-t run needs them (slow to import)

    y0 = _f(r, d)
    if y0 == 0.0:
        return -1.0, 0.0, [r], [y0]
    v = r * y0 + math.sqrt(d) * special.beta(0.5, d / 2.0) * stats.t.sf(r, d)  # base: rectangle + tail ∫_r^∞ f
    X, Y = [r], [y0]
    for _ in range(1, LAYERS - 1):
        y = Y[-1] + v / X[-1]
        if y >= 1.0:
            return None, v, X, Y
        Y.append(y)
        X.append(math.sqrt(d * math.expm1(-2.0 / (d + 1.0) * math.log(y))))  # f⁻¹(y)
    return Y[-1] + v / X[-1] - 1.0, v, X, Y


@lru_cache(maxsize=32)
def student_table(dof: float) -> np.ndarray:
    """The ziggurat of t_d (module docstring): rows width, inner edge, bottom and top height of each layer (layer 0
    the base: width v/f(r), inner edge r). r by bisection until the top layer closes at f(0) = 1 (to ≈ 1e-14)."""
    d = float(dof)
    lo, hi = 1.0, 1e6
    for _ in range(400):
        mid = math.sqrt(lo * hi) if hi > 2.0 * lo else 0.5 * (lo + hi)
        over = _climb(mid, d)[0]
        if over is None or over > 0.0:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-15 * hi:
            break
    _, v, X, Y = _climb(hi, d)
    tab = np.empty((4, LAYERS))
    tab[:, 0] = v / Y[0], hi, 0.0, Y[0]
    for i in range(1, LAYERS):
        top = i == LAYERS - 1
        tab[:, i] = X[i - 1], 0.0 if top else X[i], Y[i - 1], 1.0 if top else Y[i]
    tab.flags.writeable = False
    return tab


_NO_TABLE = np.zeros((4, 1))
_NO_TABLE.flags.writeable = False


def law_table(noise: str, dof: float) -> np.ndarray:
    """What the loops need to draw ``noise`` (:data:`LAWS`): the ziggurat of t_d, or an empty table (read-only both,
    so that the loops are compiled once)."""
    return student_table(dof) if noise == "student" else _NO_TABLE
