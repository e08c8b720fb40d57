"""Independent references for the tests: the papers' formulas written out with scipy, nothing taken from isl_core
but the model's matrices (A0, A, E, C), which are definitions, not results.

* :func:`kbf_gain` — the stationary Kalman–Bucy gain ``K = σ⁻²ΔCᵀ``, Δ from scipy's CARE (A.21–A.23).
* :func:`mismatched_ratios` — a fixed gain K̄ designed for σ̄ run at σ: ``(A − K̄C)P + P(A − K̄C)ᵀ + β²EEᵀ + σ²K̄K̄ᵀ
  = 0``, ratios ``√(P_ii/Δ_ii)`` (the mismatched Kalman–Bucy filter of the docs' theory page).
* :func:`isl_coefficients` — the ISL power law's coefficients ``c_i = G_i1 γ_{p_i}^{−1/2} ν^{i/m}``,
  ``p_i = 2(1 − i/m)``, G the CARE solution of the normalized white-noise model (A.10, A.17, B.17, B.27).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import solve_continuous_are, solve_continuous_lyapunov


def _matrices(alpha: float, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A0 (ones above the diagonal), A = A0 − αEEᵀ, E = e_m (m, 1), C = e_1ᵀ (1, m) (A.1–A.6)."""
    A0 = np.eye(m, k=1)
    E = np.zeros((m, 1))
    E[-1, 0] = 1.0
    C = np.zeros((1, m))
    C[0, 0] = 1.0
    return A0, A0 - alpha * (E @ E.T), E, C


def care(alpha: float, beta: float, sigma: float, m: int) -> np.ndarray:
    """Δ of ``AΔ + ΔAᵀ + β²EEᵀ − σ⁻²ΔCᵀCΔ = 0`` (A.23), by scipy."""
    _, A, E, C = _matrices(alpha, m)
    return solve_continuous_are(A.T, C.T, beta**2 * (E @ E.T), np.array([[sigma**2]]))


def kbf_gain(alpha: float, beta: float, sigma: float, m: int) -> np.ndarray:
    """The stationary Kalman–Bucy gain K = σ⁻²ΔCᵀ (m,) (A.22)."""
    return care(alpha, beta, sigma, m)[:, 0] / sigma**2


def mismatched_ratios(alpha: float, beta: float, sigma: float, sigma_design: float, m: int) -> np.ndarray:
    """RMSE ratios √(P_ii/Δ_ii) (m,) of the gain designed for ``sigma_design`` when the noise is ``sigma``."""
    _, A, E, C = _matrices(alpha, m)
    K = kbf_gain(alpha, beta, sigma_design, m)
    closed = A - np.outer(K, C[0])
    P = solve_continuous_lyapunov(closed, -(beta**2 * (E @ E.T) + sigma**2 * np.outer(K, K)))
    return np.sqrt(np.diag(P) / np.diag(care(alpha, beta, sigma, m)))


def worst_fixed_gain(alpha: float, w: float, m: int, sigmas, designs) -> float:
    """min over designs σ̄ of max over σ and coordinates of the mismatched ratio, β = w√(2α) (A.25)."""
    beta = w * math.sqrt(2.0 * alpha)
    return min(max(float(mismatched_ratios(alpha, beta, s, d, m).max()) for s in sigmas) for d in designs)


def gamma_abs(p: float) -> float:
    """γ_p = E|U|^p = 2^{p/2} Γ((p+1)/2)/√π for U ~ N(0, 1)."""
    return 2.0 ** (p / 2) * math.gamma((p + 1) / 2) / math.sqrt(math.pi)


def isl_coefficients(m: int, nu: float) -> np.ndarray:
    """c_i = G_i1 γ_{p_i}^{−1/2} ν^{i/m}, p_i = 2(1 − i/m), with ``A0 G + G A0ᵀ + EEᵀ − GCᵀCG = 0`` (A.17, B.17)."""
    A0, _, E, C = _matrices(0.0, m)
    G = solve_continuous_are(A0.T, C.T, E @ E.T, np.eye(1))
    i = np.arange(1, m + 1)
    return np.array([G[k - 1, 0] / math.sqrt(gamma_abs(2.0 * (1.0 - k / m))) * nu ** (k / m) for k in i])
