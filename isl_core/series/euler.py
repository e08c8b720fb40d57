"""The simulation's Kalman–Bucy filter over a series read on its own Euler grid: a simulated run downloaded as CSV and
read back gives the run's X̂ again (:ref:`data-readings`).

A series of readings every h, each the observation's average over the interval before it
(``z_k = (Y(t_k) − Y(t_{k−1}))/h``, what :func:`isl_core.simulate` gives with ``readings=True``), is the input of
the simulation's Euler step of the Kalman–Bucy filter (B.30, A.21):

    X̂_k = X̂_{k−1} + h·A·X̂_{k−1} + K·(ΔY_k − h·X̂_{1,k−1}) = M·X̂_{k−1} + h·K·z_k,      M = I + h(A − K C)

with the stationary gain K of :func:`isl_core.kalman_bucy`. It is a linear time-invariant recursion in the readings,
run here by scipy's ``dlsim``; the simulation runs the same step in error coordinates. (The series filters of
:mod:`isl_core.series.run` discretize between readings exactly instead: on a fine grid they differ from the Euler
step by O(h).)
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ..model import Model
from ..riccati import kalman_bucy
from .record import Series

__all__ = ["euler_kalman_bucy"]


def euler_kalman_bucy(series: Series, model: Model, start: npt.ArrayLike, h: float | None = None) -> np.ndarray:
    """The Euler-grid Kalman–Bucy filter of ``model`` (its σ included) over ``series`` from X̂(t_1) = ``start``
    (module docstring): the estimates (N, m) at the series' times.

    ``h``: the grid's step (default the series' interval, which must then be regular); given, the times must lie on
    the grid t_1 + k·h to 10⁻⁸ of their size (a CSV file's 9 significant digits). Every reading after the first
    must be present (the first time's reading, which the start replaces, may be missing)."""
    from scipy.signal import dlsim

    start = np.asarray(start, dtype=float)
    if start.shape != (model.m,):
        raise ValueError(f"start must hold the m = {model.m} coordinates of X̂ at the first time, got {start.shape}")
    if h is None:
        if not series.regular:
            raise ValueError("the series must be read every h (regular times): it is the Euler grid of a simulation")
        h = series.spacing
    else:
        grid = series.t[0] + h * np.arange(series.n)
        off = float(np.max(np.abs(series.t - grid)))
        if not off <= 1e-8 * max(float(np.max(np.abs(series.t))), h):
            raise ValueError(f"the times are not the grid t_1 + k·h of h = {h:g} (off by up to {off:g})")
    z = series.z[1:]
    if not np.all(np.isfinite(z)):
        row = int(np.flatnonzero(~np.isfinite(z))[0]) + 2
        raise ValueError(f"every reading after the first must be present: row {row} has none")
    kb = kalman_bucy(model)
    K = np.asarray(kb.K, dtype=float)
    M = np.eye(model.m) + h * np.asarray(model.A, dtype=float)
    M[:, 0] -= h * K  # − h K C, C = e_1ᵀ
    B = (h * K)[:, None]
    # x_{k+1} = M x_k + B u_k with u_k = z_{k+1}: one input more (0) gives the state at the last time too
    _, _, x = dlsim((M, B, np.eye(model.m), np.zeros((model.m, 1)), h), np.append(z, 0.0)[:, None], x0=start)
    return np.asarray(x)
