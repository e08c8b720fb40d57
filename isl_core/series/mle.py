"""Maximum-likelihood fit of α, β, σ_r for a given m, and the choice of m by AIC/BIC (:ref:`data-fit`).

The log-likelihood is :func:`isl_core.series.loglik` (exact, diffuse start). It is maximized over (α·Δ̄, log β,
log σ_r) by L-BFGS-B from the best of a few starting points (α ≥ 0; α fixed when given), then polished by
Nelder–Mead. Standard errors come from the inverse of the numerical Hessian of log L in (α, β, σ_r)
(statsmodels' ``approx_hess3``); a parameter at its bound (α = 0) gets none. AIC = 2k − 2 log L, BIC = k·log n − 2 log L
with k free parameters and n the readings that enter log L. Comparing orders, every m burns the same number of
readings (:data:`isl_core.M_MAX` by default), so that their likelihoods cover the same readings.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..model import M_MAX
from ..validate import check_int, check_real
from .discretize import ONE_THREAD, Steps, steps
from .likelihood import ReadingModel, loglik_at
from .record import Series, sigma_of_reading

__all__ = ["Fit", "OrderChoice", "fit", "select_order"]

ALPHA_MAX = 50.0  #: the largest α·Δ̄ the fit tries (beyond, X_m forgets itself between two readings)


@dataclass(frozen=True)
class Fit:
    """A fitted :class:`~.likelihood.ReadingModel` ``params``; ``se`` the standard errors of (α, β, σ_r) (nan where
    none: α fixed or at 0), ``sigma`` = (A.19)'s σ = σ_r·√Δ̄ and ``sigma_se``; ``loglik``, ``aic``, ``bic``, ``k`` free
    parameters, ``n`` readings in log L, ``burn``; ``alpha_fixed`` whether α was given."""

    params: ReadingModel
    se: tuple[float, float, float]
    sigma: float
    sigma_se: float
    loglik: float
    aic: float
    bic: float
    k: int
    n: int
    burn: int
    alpha_fixed: bool

    def as_dict(self) -> dict[str, float | int | bool]:
        """The fit as plain numbers (the command line's ``fit``)."""
        p = self.params
        return {
            "m": p.m,
            "alpha": p.alpha,
            "beta": p.beta,
            "sigma": self.sigma,
            "sigma_r": p.sigma_r,
            "alpha_se": self.se[0],
            "beta_se": self.se[1],
            "sigma_se": self.sigma_se,
            "sigma_r_se": self.se[2],
            "alpha_fixed": self.alpha_fixed,
            "loglik": self.loglik,
            "aic": self.aic,
            "bic": self.bic,
            "n": self.n,
        }


def _hessian(f: Callable[[np.ndarray], float], x: np.ndarray) -> np.ndarray:
    try:
        from statsmodels.tools.numdiff import approx_hess3
    except ImportError as exc:  # pragma: no cover - the data extra is missing
        raise ImportError("standard errors need statsmodels: pip install 'isl[data]'") from exc
    return np.atleast_2d(approx_hess3(x, f))


def _se(series: Series, p: ReadingModel, burn: int, alpha_free: bool, grid: Steps) -> tuple[float, float, float]:
    free_alpha = alpha_free and p.alpha > 1e-6 / series.spacing
    x = np.array([p.alpha, p.beta, p.sigma_r] if free_alpha else [p.beta, p.sigma_r])

    def ll(v: np.ndarray) -> float:
        a, b, s = v if free_alpha else (p.alpha, *v)
        if a < 0 or b <= 0 or s <= 0:
            return -np.inf
        with np.errstate(all="ignore"):
            return loglik_at(series, ReadingModel(p.m, a, b, s), grid, burn=burn)

    with np.errstate(over="ignore", invalid="ignore"):  # parameters near the float range's end (β of dense times
        H = _hessian(ll, x)  # and huge readings): the steps' products overflow, and no standard error is given
    with np.errstate(invalid="ignore"):
        try:
            cov = np.linalg.inv(-H)
            se = np.sqrt(np.where(np.diag(cov) > 0, np.diag(cov), np.nan))
        except np.linalg.LinAlgError:
            se = np.full(len(x), np.nan)
    return (float(se[0]), float(se[1]), float(se[2])) if free_alpha else (math.nan, float(se[0]), float(se[1]))


def _starts(series: Series, m: int, alphas: Sequence[float]) -> list[np.ndarray]:
    """Starting points (α·Δ̄, log β, log σ_r): σ_r from the differences' scatter, β over four decades around the one
    whose m-th difference has the readings' scale."""
    dt = series.spacing
    z = series.z[series.present]
    s = float(np.std(np.diff(z))) or float(np.std(z)) or 1.0
    base = math.log(s) - (m - 0.5) * math.log(dt)
    return [np.array([a, base + c, math.log(s / math.sqrt(2.0))]) for a in alphas for c in (-4.6, -2.3, 0.0, 2.3)]


@ONE_THREAD
def fit(series: Series, m: int, *, alpha: float | None = None, burn: int | None = None) -> Fit:
    """Fit α, β, σ_r of order ``m`` to ``series`` by maximum likelihood (module docstring).

    Parameters
    ----------
    series : Series
        The readings.
    m : int
        The model's order 1 … 6.
    alpha : float, optional
        α fixed (≥ 0) instead of fitted.
    burn : int, optional
        Readings that only identify the diffuse start (default m).

    Returns
    -------
    Fit
        The parameters, their standard errors, log L, AIC and BIC.
    """
    from scipy.optimize import minimize  # here, not at the top: only a fit needs it, and a page imports this module

    m = check_int("m", m, lo=1, hi=M_MAX)
    if np.ptp(series.z[series.present]) == 0.0:
        raise ValueError("the readings are all equal: there is no motion or noise to fit")
    fixed = alpha is not None
    a_fix = check_real("alpha", alpha, lo=0.0) if alpha is not None else 0.0
    burn = m if burn is None else check_int("burn", burn, lo=m, hi=M_MAX)
    dt = series.spacing
    grid = steps(series.t)

    def params(v: np.ndarray) -> ReadingModel:
        a = a_fix if fixed else max(float(v[0]), 0.0) / dt
        return ReadingModel(m, a, math.exp(v[1]), math.exp(v[2]))

    seen: list[Any] = [math.inf, None]  # the best point either optimizer evaluated (one may end at a non-finite one)

    def cost(v: np.ndarray) -> float:
        if not np.all(np.isfinite(v)) or abs(v[1]) > 600 or abs(v[2]) > 600:
            return 1e300
        with np.errstate(all="ignore"):  # an exploratory α may overflow the exponential: log L is then not finite
            ll = loglik_at(series, params(v), grid, burn=burn)
        c = -ll if math.isfinite(ll) else 1e300
        if c < seen[0]:
            seen[:] = [c, np.array(v, dtype=float)]
        return c

    starts = _starts(series, m, [a_fix * dt] if fixed else [0.0, 0.1, 1.0])
    best = min(starts, key=cost)
    bounds = [(a_fix * dt, a_fix * dt) if fixed else (0.0, ALPHA_MAX), (None, None), (None, None)]
    res = minimize(cost, best, method="L-BFGS-B", bounds=bounds, options={"ftol": 1e-13, "gtol": 1e-7, "maxiter": 300})
    # L-BFGS-B's finite-difference gradient stops it where log L is flat to its noise: Nelder–Mead from a small
    # simplex about that point takes the last digits (10⁻⁴ relative where statsmodels is the peer)
    simplex = res.x + np.vstack([np.zeros(3), 1e-3 * np.eye(3)])
    res = minimize(
        lambda v: cost(np.array([min(max(v[0], bounds[0][0]), bounds[0][1]), v[1], v[2]])),
        res.x,
        method="Nelder-Mead",
        options={"xatol": 1e-7, "fatol": 1e-9, "maxiter": 300, "initial_simplex": simplex},
    )
    cost(np.array([min(max(res.x[0], bounds[0][0]), bounds[0][1]), res.x[1], res.x[2]]))
    x = np.array([min(max(seen[1][0], bounds[0][0]), bounds[0][1]), seen[1][1], seen[1][2]])
    p = params(x)
    ll = loglik_at(series, p, grid, burn=burn)
    se = _se(series, p, burn, not fixed, grid)
    k = 2 if fixed else 3
    n = int(series.present.sum()) - burn
    return Fit(
        p,
        se,
        sigma_of_reading(p.sigma_r, dt),
        se[2] * math.sqrt(dt),
        ll,
        2.0 * k - 2.0 * ll,
        k * math.log(n) - 2.0 * ll,
        k,
        n,
        burn,
        fixed,
    )


@dataclass(frozen=True)
class OrderChoice:
    """Fits of every order of ``orders`` (``fits``, same order) on the same readings, and the ``best`` by BIC."""

    fits: tuple[Fit, ...]
    best: Fit


@ONE_THREAD
def select_order(
    series: Series,
    orders: Sequence[int] = tuple(range(1, M_MAX + 1)),
    *,
    alpha: float | None = None,
    progress: Callable[[float], None] | None = None,
    cancel: Callable[[], bool] | None = None,
) -> OrderChoice:
    """Fit every m of ``orders`` with the same burn (the largest m) and choose the one of least BIC.

    ``progress`` gets the share done after each order; ``cancel`` (when true) stops before the next order, with
    ``InterruptedError``.
    """
    orders = tuple(check_int("m", m, lo=1, hi=M_MAX) for m in orders)
    if not orders:
        raise ValueError("orders must name at least one m in 1 … 6")
    burn = max(orders)
    fits = []
    for j, m in enumerate(orders):
        if cancel is not None and cancel():
            raise InterruptedError("the fit was cancelled")
        fits.append(fit(series, m, alpha=alpha, burn=burn))
        if progress is not None:
            progress((j + 1) / len(orders))
    return OrderChoice(tuple(fits), min(fits, key=lambda f: f.bic))
