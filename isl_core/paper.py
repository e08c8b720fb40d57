"""The papers' published settings and their one published result, as the papers give them (cited, never computed).

Paper A: N. A. Kuznetsov, M. V. Lebedev, K. V. Semenikhin, "Nonlinear filter of a process with correlated derivative
in the presence of unknown noise intensity" (Нелинейный фильтр процесса с коррелированной производной при
неизвестной интенсивности шума в наблюдениях), Information Processes (Информационные процессы), vol. 25, no. 3.1,
2025, DOI 10.53921/18195822_2025_25_3.1_648. Equation numbers (A.n).

Paper B: N. A. Kuznetsov, K. V. Semenikhin, "A nonlinear filtering method under unknown noise intensity in the
observations" (Метод нелинейной фильтрации при неизвестной интенсивности шума в наблюдениях), Informatics and
Automation (Информатика и автоматизация, SPIIRAS Proceedings), vol. 24, no. 6, 2025. Equation numbers (B.n).

Everything here is an *input* or a *reference value*: the grids of the numerical experiments (A.25–A.28, Fig. 3;
B, Fig. 2) and table (A.31), the ν/β the authors read off their Fig. 2 by eye. The project computes its own
recommendation (:func:`isl_core.recommend_nu`) and shows it beside this table, labelled as the paper's.
"""

from __future__ import annotations

import math
from types import MappingProxyType

__all__ = [
    "A31_NU_OVER_BETA",
    "FIG2_ALPHAS",
    "FIG2_NU_OVER_BETA",
    "FIG2_SIGMAS",
    "FIG3",
    "PAPER_A",
    "PAPER_B",
    "PAPER_B_FIG2",
    "M",
    "W",
    "a31_nu_over_beta",
]

PAPER_A = (
    "N. A. Kuznetsov, M. V. Lebedev, K. V. Semenikhin. Nonlinear filter of a process with correlated derivative "
    "in the presence of unknown noise intensity. Information Processes, 25(3.1), 2025. "
    "DOI 10.53921/18195822_2025_25_3.1_648"
)
PAPER_B = (
    "N. A. Kuznetsov, K. V. Semenikhin. A nonlinear filtering method under unknown noise intensity in the "
    "observations. Informatics and Automation (SPIIRAS Proceedings), 24(6), 2025"
)

M = 3  #: paper A's experiments: a third-order state (m = q + 1 = 3, A.2)
W = 3.0  #: stationary standard deviation of X_m: β²/(2α) = w², w = 3 (A.25)
FIG2_ALPHAS = (1 / 25, 1 / 5, 1.0, 5.0, 25.0)  #: the rows of Fig. 2 (A.26)
FIG2_SIGMAS = (2.0, 20.0, 200.0)  #: the line styles of Fig. 2 (A.27)
FIG2_NU_OVER_BETA = tuple(2.0**ell for ell in range(-8, 3))  #: the abscissae ν = 2^ℓ β, ℓ = −8..2 (A.28)

#: Fig. 3 of paper A: m = 3, α = 0.5, w = 3 (so β = w√(2α) = 3), ν = β, σ = 20 and 200, T = 10/r_min
FIG3 = MappingProxyType({"m": 3, "alpha": 0.5, "w": 3.0, "nu_over_beta": 1.0, "sigmas": (20.0, 200.0), "horizon": 10.0})
#: Fig. 2 of paper B: the white-noise model α = 0, m = 3, β = 3, ν = β, σ = 5 and 50
PAPER_B_FIG2 = MappingProxyType({"m": 3, "alpha": 0.0, "beta": 3.0, "nu_over_beta": 1.0, "sigmas": (5.0, 50.0)})

#: Table (A.31): the recommended ν/β per α, read off Fig. 2 by eye (m = 3, w = 3, σ ∈ {2, 20, 200})
A31_NU_OVER_BETA = MappingProxyType({0.04: 1.0, 0.2: 0.7, 1.0: 0.2, 5.0: 0.03, 25.0: 0.01})


def a31_nu_over_beta(alpha: float, m: int = M, w: float = W) -> float | None:
    """Table (A.31)'s ν/β for this α, or None: the table holds only paper A's five α (to 1e-12), for m = 3, w = 3."""
    if m != M or w != W:
        return None
    for a, nob in A31_NU_OVER_BETA.items():
        if math.isclose(alpha, a, rel_tol=1e-12):
            return nob
    return None
