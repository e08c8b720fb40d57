"""What every filter is: a :class:`FilterSpec` for the fused simulation, and the kernels' codes of its kind (B.30, B.32,
A.18).

Every filter here has the form (on the grid t_k = k·h, innovation u_k = ΔY_k/√h − √h·Z_1(t_k))

    Z(t_{k+1}) = (I + h·(A0 − a·E Eᵀ))·Z(t_k) + √h·φ(u_k)

with a propagation damping ``a`` (0 → A0 as in paper A's ISL filter; α → the true A) and φ either
linear, ``φ(u) = K u`` (then the step is the Kalman–Bucy scheme B.30), or the power law of (A.17),
``φ_i(u) = c_i sign(u)|u|^{1−i/m}`` (the ISL scheme A.18), or linear with a gain ``K(σ̂_k)`` that follows an
online estimate of σ (the adaptive Kalman–Bucy filter of :mod:`!isl_core.filters.adaptive`, described by an
:class:`AdaptiveGain`), or — in scenario runs only — the variational-Bayes adaptive Kalman filter of
:mod:`isl_core.filters.variational` (a :class:`VariationalGain`), which carries its own covariance, or the bank of
Kalman filters of the interacting-multiple-model filter of :mod:`isl_core.filters.imm` (an :class:`IMMBank`).

The constructors are the family modules of :mod:`isl_core.filters`: :mod:`~isl_core.filters.kalman` (the
Kalman–Bucy filters: optimal, mismatched, minimax), :mod:`~isl_core.filters.isl` (paper A's and the model-aware ISL
filters), :mod:`!isl_core.filters.adaptive`, :mod:`~isl_core.filters.robust`, :mod:`~isl_core.filters.variational`,
:mod:`~isl_core.filters.imm`; :mod:`~isl_core.filters.baselines` names the set a user without σ compares.

Symbols: ``damp`` = a, ``coef`` = K or c, ``power`` selects the power law, ``adaptive`` the σ̂-driven gain;
``kind`` is the kernels' code of φ, one named constant each — :data:`!KIND_LINEAR`, :data:`!KIND_POWER`,
:data:`!KIND_ADAPTIVE`, :data:`KIND_CLAIRVOYANT`, :data:`KIND_VB`, :data:`KIND_ROBUST`, :data:`KIND_IMM` — module
ints that the compiled kernels read as compile-time constants (never a bare number).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import numpy as np

from ..model import Model
from ..nonlinearity import exponents_at, linearization_at

__all__ = [
    "KIND_ADAPTIVE",
    "KIND_CLAIRVOYANT",
    "KIND_IMM",
    "KIND_LINEAR",
    "KIND_POWER",
    "KIND_ROBUST",
    "KIND_VB",
    "SIGMA_RANGE",
    "AdaptiveGain",
    "FilterSpec",
    "IMMBank",
    "VariationalGain",
    "linearized_matrix",
]

#: the σ range a σ-learner assumes by default (its gain table, its start at the geometric middle): the ends of paper
#: A's Fig. 2 σ values
SIGMA_RANGE = (2.0, 200.0)
KIND_LINEAR = 0  #: φ linear, K u (B.30)
KIND_POWER = 1  #: φ the power law of (A.17)
KIND_ADAPTIVE = 2  #: φ linear with the gain K(σ̂) of an online σ estimate (:mod:`!isl_core.filters.adaptive`)
KIND_CLAIRVOYANT = 3  #: the scenario loop's Kalman filter that knows σ(t) (:mod:`isl_core.scenario`)
KIND_VB = 4  #: the variational-Bayes filter (:mod:`isl_core.filters.variational`)
KIND_ROBUST = 5  #: the adaptive filter with Huber-clipped innovations (:mod:`isl_core.filters.robust`)
KIND_IMM = 6  #: the interacting-multiple-model bank of Kalman filters (:mod:`isl_core.filters.imm`)


@dataclass(frozen=True)
class IMMBank:
    """The IMM filter's bank (:mod:`isl_core.filters.imm`): its modes' σ_j (J,), the switch probability p per reading
    and each mode's covariance at the start (J, m, m), the stationary Δ of its σ_j (A.23)."""

    sigmas: np.ndarray
    switch: float
    cov: np.ndarray


@dataclass(frozen=True)
class VariationalGain:
    """The variational-Bayes adaptive Kalman filter's settings (:mod:`isl_core.filters.variational`): memory W in sensor
    readings (forgetting factor ρ = 1 − 1/W per reading), σ̂ and the inverse-gamma shape α₀ before the first reading,
    fixed-point iterations per reading."""

    memory: float
    sigma_init: float
    shape0: float
    iterations: int

    @property
    def rho(self) -> float:
        """ρ = 1 − 1/W: a⁻ = ρa, b⁻ = ρb at each reading."""
        return 1.0 - 1.0 / self.memory


@dataclass(frozen=True)
class AdaptiveGain:
    """The σ̂ → K(σ̂) map and the variance estimator of an adaptive Kalman–Bucy filter (:ref:`adaptive-kbf`).

    ``log_gain`` (n, m) holds ``log K_i`` of the stationary gain (A.21–A.23) on the equally spaced grid
    ``log σ_j = log_sigma0 + j·step``, j = 0..n−1; between grid points log K is linear in log σ, outside the
    grid it is held at the end values. ``memory`` W (sensor readings) bounds the forgetting factor
    ``λ_r = max(1/r, 1/W)`` of the innovation variance at the r-th reading; ``sigma_init`` is σ̂ before the first
    innovation. ``sigma_range`` (σ_min, σ_max) is the range the filter states for σ: in a scenario run
    (:mod:`!isl_core.kernels.scenario`) σ̂ is held inside it, so that the estimate cannot run away beyond what the
    filter assumes; the gain table reaches beyond it only so that K(σ̂) is smooth at its ends.
    """

    log_sigma0: float
    step: float
    log_gain: np.ndarray
    memory: float
    sigma_init: float
    sigma_range: tuple[float, float] = (0.0, math.inf)

    @property
    def sigmas(self) -> np.ndarray:
        """The grid σ_j (n,)."""
        return cast("np.ndarray", np.exp(self.log_sigma0 + self.step * np.arange(len(self.log_gain))))

    def gain(self, sigma: float) -> np.ndarray:
        """K(σ) (m,) interpolated from the table: log K linear in log σ, held constant beyond the ends."""
        x = np.log(self.sigmas)
        return np.exp([np.interp(np.log(sigma), x, col) for col in self.log_gain.T])


@dataclass(frozen=True)
class FilterSpec:
    """One filter of the fused kernel: ``Z ← (I + h(A0 − damp·EEᵀ))Z + √h φ(u)`` (B.30 / A.18).

    ``adaptive`` (optional) makes φ linear with the gain K(σ̂_k) of an online σ estimate; ``coef`` is then the
    gain before the first innovation, K(``adaptive.sigma_init``).
    """

    name: str
    label: str
    damp: float
    coef: np.ndarray
    power: bool
    adaptive: AdaptiveGain | None = None
    variational: VariationalGain | None = None
    huber: float | None = None  #: with ``adaptive``: innovations clipped at ± huber·σ̂ (scenario runs only)
    imm: IMMBank | None = None  #: the interacting-multiple-model filter's bank (scenario runs only)

    @property
    def kind(self) -> int:
        """The kernel's code: :data:`!KIND_ADAPTIVE`, :data:`!KIND_POWER`, :data:`!KIND_LINEAR`, … (see the module)."""
        if self.imm is not None:
            return KIND_IMM
        if self.variational is not None:
            return KIND_VB
        if self.adaptive is not None:
            return KIND_ROBUST if self.huber is not None else KIND_ADAPTIVE
        return KIND_POWER if self.power else KIND_LINEAR

    def exponents(self) -> np.ndarray:
        """Exponents q_i of φ: all 1 for a linear gain, ``1 − i/m`` for the power law (A.17)."""
        m = len(self.coef)
        return exponents_at(m) if self.power else np.ones(m)


def linearized_matrix(model: Model, spec: FilterSpec) -> np.ndarray:
    """``Λ = A0 − a·EEᵀ − σ⁻² L C`` of the statistically linearized filter (B.46), true σ of ``model``.

    Parameters
    ----------
    model : Model
        The model (its σ).
    spec : FilterSpec
        The filter.

    Returns
    -------
    numpy.ndarray
        Λ (m, m); stable (every eigenvalue with a negative real part) for a filter that keeps lock.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import isl_filter, linearized_matrix
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> lam = linearized_matrix(model, isl_filter(model, model.beta))
    >>> lam.shape, bool(np.all(np.linalg.eigvals(lam).real < 0))
    ((3, 3), True)
    """
    L, _ = linearization_at(spec.coef, spec.exponents(), model.sigma)  # the model's σ: checked when it was made
    lam = model.A0
    lam[-1, -1] -= spec.damp
    lam[:, 0] -= L / model.sigma**2  # (B.46)
    return lam
