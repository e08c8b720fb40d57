"""The signal-and-observation model (A.1–A.6, A.14, A.19–A.20).

State ``X = (X_1..X_m)``, ``X_i`` the (i−1)-th derivative of a scalar signal:

    dX_i = X_{i+1} dt              (i < m)
    dX_m = −α X_m dt + β dv        (Ornstein–Uhlenbeck top derivative, A.5)
    dY   = X_1 dt + σ dε           (observation, A.6; σ unknown to the ISL filter)

Symbols: ``A0`` ones on the superdiagonal (A.11), ``E = e_m``, ``C = e_1ᵀ``, ``A = A0 − α E Eᵀ`` (A.20).
α = 0 is the white-noise-derivative model of paper B. Paper A fixes ``β²/(2α) = w²`` (A.25).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .bounds import BOUNDS, M_MAX

__all__ = ["M_MAX", "Model", "shift_matrix"]


def shift_matrix(m: int) -> np.ndarray:
    """``A0``: ones on the superdiagonal, size m×m (A.11)."""
    return np.eye(m, k=1)


@dataclass(frozen=True)
class Model:
    """Model (A.19): ``dX = A X dt + β E dv``, ``dY = C X dt + σ dε``.

    Parameters are validated at construction against their domains in :data:`!isl_core.bounds.BOUNDS`: ``alpha``
    finite ≥ 0, ``beta`` and ``sigma`` finite > 0, ``m`` an integer 1 … :data:`M_MAX`.

    Parameters
    ----------
    alpha : float
        Ornstein–Uhlenbeck rate α ≥ 0 of the last coordinate (α = 0: paper B's model).
    beta : float
        Intensity β > 0 of the driving noise.
    sigma : float
        Intensity σ > 0 of the observation noise.
    m : int, default 3
        State dimension, 1 … :data:`M_MAX`.

    Examples
    --------
    >>> import math
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)  # paper A's Fig. 3: w = 3, σ = 20
    >>> model.m, model.beta == 3.0 * math.sqrt(2 * 0.5)
    (3, True)
    >>> Model(0.0, 1.0, 5.0, m=6).alpha  # paper B's model
    0.0
    """

    alpha: float
    beta: float
    sigma: float
    m: int = 3

    def __post_init__(self) -> None:
        for name in ("alpha", "beta", "sigma"):
            object.__setattr__(self, name, BOUNDS[name].real(getattr(self, name)))
        object.__setattr__(self, "m", BOUNDS.m.whole(self.m))

    @classmethod
    def from_w(cls, alpha: float, w: float, sigma: float, m: int = 3) -> Model:
        """Paper A's parametrization (A.25): stationary std ``w`` of X_m, so ``β = w·√(2α)``; needs α > 0."""
        a = BOUNDS.alpha.real(alpha)
        if a == 0.0:
            raise ValueError(
                "alpha must be a finite number > 0 in the parametrization β = w·√(2α) (A.25), got 0; "
                "build the α = 0 model as Model(0, beta, sigma, m)"
            )
        w = BOUNDS.w.real(w)
        return cls(a, w * math.sqrt(2.0 * a), sigma, m)

    @property
    def A0(self) -> np.ndarray:
        return shift_matrix(self.m)

    @property
    def E(self) -> np.ndarray:
        e = np.zeros((self.m, 1))
        e[-1, 0] = 1.0
        return e

    @property
    def C(self) -> np.ndarray:
        c = np.zeros((1, self.m))
        c[0, 0] = 1.0
        return c

    @property
    def A(self) -> np.ndarray:
        """``A = A0 − α E Eᵀ`` (A.20)."""
        a = self.A0
        a[-1, -1] = -self.alpha
        return a

    @property
    def stationary_var(self) -> float:
        """Variance ``β²/(2α)`` of the stationary X_m (A.25); ``inf`` when α = 0."""
        return math.inf if self.alpha == 0.0 else self.beta**2 / (2.0 * self.alpha)
