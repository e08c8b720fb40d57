"""The ISL nonlinearity φ and its statistical linearization (A.17, B.23–B.27, B.40–B.43).

    φ_i(x) = c_i · sign(x)·|x|^{q_i},   c_i = G_i1 · γ_{p_i}^{-1/2} · ν^{i/m},   q_i = 1 − i/m,  p_i = 2 q_i   (A.17)

This is paper B's power law (B.23), whose constant γ_p^{-1/2} makes its second moment match the Kalman–Bucy gain's
for every σ (B.24); with it the filter's equations (B.25) for i < m and (B.26) for i = m no longer contain σ. At
m = 3 they are paper B's explicit filter (B.54): c = (2β^{1/3}γ_{4/3}^{-1/2}, 2β^{2/3}γ_{2/3}^{-1/2}, β) at ν = β.
    γ_p    = E|U|^p = 2^{p/2} Γ((p+1)/2) / √π,   U ~ N(0, 1)

For ξ ~ N(0, σ²) the power law has closed-form moments (:ref:`linearization`):

    L_i  = E[φ_i(ξ) ξ]  = c_i γ_{1+q_i} σ^{1+q_i}                  (B.40)
    Φ_ij = E[φ_i φ_j]   = c_i c_j γ_{q_i+q_j} σ^{q_i+q_j}           (B.43)

Symbols: ``coef`` = c, ``q`` = exponents, ``L`` (m,), ``Phi`` (m, m).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .bounds import BOUNDS
from .riccati import normalized_care
from .validate import check_real

__all__ = ["gamma_abs", "gamma_moments", "isl_exponents", "isl_gains", "linearization", "linearization_at", "phi"]


def gamma_abs(p: float) -> float:
    """Absolute moment ``γ_p = E|U|^p = 2^{p/2} Γ((p+1)/2)/√π`` of U ~ N(0, 1), for p > −1.

    Parameters
    ----------
    p : float
        The order, > −1.

    Returns
    -------
    float
        The moment γ_p.

    Examples
    --------
    >>> import math
    >>> from isl_core import gamma_abs
    >>> gamma_abs(0.0), math.isclose(gamma_abs(2.0), 1.0)  # E|U|^0 = 1, E U² = 1
    (1.0, True)
    """
    p = check_real("p", p, lo=-1.0, lo_open=True)
    moment: float = 2.0 ** (p / 2.0) * math.gamma((p + 1.0) / 2.0) / math.sqrt(math.pi)
    return moment


def isl_exponents(m: int) -> np.ndarray:
    """Exponents ``q_i = 1 − i/m``, i = 1..m, of the power laws in (A.17).

    Parameters
    ----------
    m : int
        State dimension.

    Returns
    -------
    numpy.ndarray
        The exponents q_1 … q_m, from 1 − 1/m down to 0.

    Examples
    --------
    >>> from isl_core import isl_exponents
    >>> isl_exponents(2).tolist()
    [0.5, 0.0]
    """
    return exponents_at(BOUNDS.m.whole(m))


def exponents_at(m: int) -> np.ndarray:
    """:func:`isl_core.isl_exponents` of an m already checked (a filter's size): a filter's φ is read at every step
    of its run and need not check its own size each time."""
    return 1.0 - np.arange(1, m + 1) / m


def isl_gains(m: int, nu: float) -> np.ndarray:
    """Coefficients ``c_i = G_i1 γ_{p_i}^{-1/2} ν^{i/m}`` of φ (A.17), p_i = 2(1 − i/m).

    Parameters
    ----------
    m : int
        State dimension.
    nu : float
        The tuning ν > 0.

    Returns
    -------
    numpy.ndarray
        The m coefficients c_1 … c_m, each > 0; with :func:`isl_exponents` they define φ (:func:`phi`).

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import isl_gains
    >>> c = isl_gains(3, 2.0)
    >>> c.shape, bool(np.all(c > 0))
    ((3,), True)
    """
    return gains_at(BOUNDS.m.whole(m), BOUNDS.nu.real(nu))


def gains_at(m: int, nu: float) -> np.ndarray:
    """:func:`isl_core.isl_gains` of an m and a ν already checked (the ISL filter's: its model's m, and the ν its
    constructor checks), so that a run checks each once."""
    g1 = normalized_care(m, 0.0)[:, 0]  # G(m), (A.10)
    q = exponents_at(m)
    i = np.arange(1, m + 1)
    gam = np.array([gamma_abs(2.0 * qi) for qi in q])
    coef: np.ndarray = g1 / np.sqrt(gam) * nu ** (i / m)  # (A.17)
    return coef


def phi(x: np.ndarray | float, coef: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Evaluate ``φ_i(x) = c_i sign(x)|x|^{q_i}`` (A.17); returns shape ``x.shape + (m,)``.

    Parameters
    ----------
    x : float or numpy.ndarray
        Where φ is evaluated.
    coef : numpy.ndarray
        The coefficients c_i (m,), :func:`isl_gains`.
    q : numpy.ndarray
        The exponents q_i (m,), :func:`isl_exponents`.

    Returns
    -------
    numpy.ndarray
        The values φ_i(x), one column per i.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import isl_exponents, isl_gains, phi
    >>> y = phi(np.array([-1.0, 0.0, 2.0]), isl_gains(3, 1.0), isl_exponents(3))
    >>> y.shape, bool(np.all(y[1] == 0.0)), bool(np.all(np.sign(y[0]) == -np.sign(y[2])))
    ((3, 3), True, True)
    """
    x = np.asarray(x, dtype=float)[..., None]
    values: np.ndarray = coef * np.sign(x) * np.abs(x) ** q
    return values


def linearization(coef: np.ndarray, q: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form ``L = E[φ(ξ)ξ]`` and ``Φ = E[φ(ξ)φ(ξ)ᵀ]`` for ξ ~ N(0, σ²) (B.40, B.43).

    A linear φ (q = 1) gives ``L = σ² c`` and ``Φ = σ² c cᵀ``.

    Parameters
    ----------
    coef, q : numpy.ndarray
        φ's coefficients and exponents (m,).
    sigma : float
        The standard deviation σ > 0 of ξ.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        L (m,) and Φ (m, m).

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import linearization
    >>> c = np.array([1.0, 2.0])
    >>> L, Phi = linearization(c, np.ones(2), 3.0)  # a linear φ
    >>> bool(np.allclose(L, 9.0 * c) and np.allclose(Phi, 9.0 * np.outer(c, c)))
    True
    """
    return linearization_at(coef, q, BOUNDS.sigma.real(sigma))


def linearization_at(coef: np.ndarray, q: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`isl_core.linearization` at a σ already checked (a :class:`isl_core.Model`'s): the core's own filters
    linearize at their model's σ once per filter and per grid, and need not check it again each time."""
    coef = np.asarray(coef, dtype=float)
    q = np.asarray(q, dtype=float)
    g1, g2 = gamma_moments(tuple(float(x) for x in q))
    L = coef * g1 * sigma ** (1.0 + q)  # (B.40)
    qq = q[:, None] + q[None, :]
    Phi = np.outer(coef, coef) * g2 * sigma**qq  # (B.43)
    return L, Phi


@lru_cache(maxsize=64)
def gamma_moments(q: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """``γ_{1+q_i}`` (m,) and ``γ_{q_i+q_j}`` (m, m) for the exponents ``q`` (read-only; cached: a dashboard run
    linearizes eight filters with the same exponents). ``isl_core.clear_caches`` empties the cache."""
    g1 = np.array([gamma_abs(1.0 + qi) for qi in q])
    g2 = np.array([[gamma_abs(qi + qj) for qj in q] for qi in q])
    g1.flags.writeable = g2.flags.writeable = False
    return g1, g2
