"""Scenarios beyond constant σ, and the clairvoyant reference that knows them (:ref:`scenarios`).

A :class:`Scenario` is one value that says what the world does beyond paper A's model; ``Scenario()`` is that model
(σ constant, Gaussian noise, a sensor that is read at every step) and :attr:`Scenario.is_default` says so.

**σ(t).** ``sigma_knots = ((t_1, σ_1), …, (t_J, σ_J))``, times in units of 1/r_min of the model at σ(0) =
``model.sigma`` (A.24), strictly increasing from t_1 > 0. With ``sigma_shape = "steps"``, σ(t) = σ_j for
t_j ≤ t < t_{j+1} (σ(0) before t_1); with ``"drift"``, log σ is linear in t between the knots (0, σ(0)), (t_1, σ_1),
…, and σ_J holds after t_J. On the grid, step k → k+1 uses σ_k = σ(t_k).

**Observation noise**, per step of the Euler grid ``ΔY_k = h·X_1(t_k) + σ_k·√h·ε_k`` (B.34):

* ``"gaussian"``: ε_k ~ N(0, 1);
* ``"student"``: ε_k = √((d − 2)/d)·T_d, Student's t with d > 2 degrees of freedom (``dof``) scaled to unit
  variance;
* ``"outliers"``: ε_k ~ N(0, 1) with probability 1 − p and k·N(0, 1) with probability p (``outlier_rate`` p,
  ``outlier_scale`` k), so E ε² = 1 − p + p·k² (:meth:`Scenario.noise_variance`).

**Sensor interval** Δ = ``sensor_interval`` (1/r_min units; 0 = every step): the filters see Y only every
q = max(1, round(Δ/h)) steps, as the increment of Y over those q steps — what a sensor that integrates dY over its
interval delivers — and propagate in between (:meth:`Scenario.sensor_steps`). The truth keeps the step h, which a
scenario run takes as Δ/q exactly (:func:`isl_core.scenario_grid`), so the readings are the sensor's whatever the step;
a table at a reading rate R sets Δ = 1/R (:func:`isl_core.scenario.presets.at_rate`, :ref:`reading-rate`).

**The clairvoyant reference** (:func:`clairvoyant`) is the Kalman filter of the simulated model — the Euler grid
above, not its continuous-time limit — that knows σ_k, the noise's variance and the sensor interval: the best
linear filter of what is simulated, and its error covariance P_k is *exact* on the grid (no Euler bias), so a
simulated clairvoyant filter's squared error averages to P_k whatever the scenario. It is started at the stationary
covariance of σ(0), the errors' start of every run. With q = 1 it is the predictor form that the other filters use,

    e_{k+1} = (F − h·K_k·C)·e_k − w_k + K_k·σ_k·√h·ε_k,   F = I + h·A,   w_k = β·√h·v_k·E          (B.30–B.34)
    K_k = h·F·P_k·Cᵀ / s_k,   s_k = h²·C·P_k·Cᵀ + h·σ_k²·E ε²,   P_{k+1} = F·P_k·Fᵀ + h·β²·E·Eᵀ − K_k·s_k·K_kᵀ

and with q > 1 the same for the state (X, S), S = h·Σ C·X over the current sensor interval, with the measurement
S + Σ σ_k·√h·ε_k at the interval's end, after which S restarts at 0. For constant σ, Gaussian noise and q = 1,
P_k settles at the grid's stationary covariance, within O(h) (the grid's Euler bias, :mod:`isl_core.grid`) of the
Kalman–Bucy Δ of (A.23): it is then today's optimal filter.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np

from ..kernels.bundles import NoiseLaw
from ..kernels.clairvoyant import clairvoyant_state, riccati_path
from ..kernels.draws import fill
from ..model import Model
from ..noise import LAWS, law_table
from ..riccati import kalman_bucy
from ..validate import check_real

__all__ = ["NOISE_LAWS", "SIGMA_SHAPES", "Clairvoyant", "Scenario", "clairvoyant", "sigma_path"]

NOISE_LAWS = tuple(LAWS)  #: "gaussian", "student", "outliers"
SIGMA_SHAPES = ("steps", "drift")
SIGMA_BOUNDS = (1e-3, 1e6)  #: σ values a knot may take (those of the model's σ in the core)
TIME_MAX = 1e6  #: latest knot time, in units of 1/r_min
DOF_MAX = 1e6  #: Student's t beyond this many degrees of freedom is Gaussian to float precision
OUTLIER_SCALE_MAX = 1e4


def _choice(name: str, value: object, choices: tuple[str, ...]) -> str:
    if not isinstance(value, str) or value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(choices)}; got {value!r}")
    return value


@dataclass(frozen=True)
class Scenario:
    """σ(t), the observation noise's law and the sensor interval (see the module docstring); validated at
    construction with a ``ValueError`` that names the parameter and its range.

    Parameters
    ----------
    sigma_knots : tuple of (float, float)
        The knots (t_j, σ_j) of σ(t), times in units of 1/r_min; empty: σ constant.
    sigma_shape : {"steps", "drift"}
        How σ goes from knot to knot.
    noise : {"gaussian", "student", "outliers"}
        The observation noise's law (:data:`!NOISE_LAWS`), with ``dof`` or ``outlier_rate`` and ``outlier_scale``.
    sensor_interval : float
        Time between sensor readings, 1/r_min units (0: every step).

    Examples
    --------
    >>> from isl_core import Scenario
    >>> Scenario().is_default
    True
    >>> drop = Scenario(sigma_knots=((10.0, 2.0),))  # σ drops to 2 at t = 10/r_min
    >>> drop.is_default, drop.noise_variance
    (False, 1.0)
    """

    sigma_knots: tuple[tuple[float, float], ...] = ()
    sigma_shape: str = "steps"
    noise: str = "gaussian"
    dof: float = 3.0
    outlier_rate: float = 0.01
    outlier_scale: float = 30.0
    sensor_interval: float = 0.0

    def __post_init__(self) -> None:
        knots, last = [], 0.0
        if not isinstance(self.sigma_knots, (tuple, list)):
            raise ValueError(f"sigma_knots must be a sequence of (time, sigma) pairs; got {self.sigma_knots!r}")
        for j, knot in enumerate(self.sigma_knots):
            if not isinstance(knot, (tuple, list)) or len(knot) != 2:
                raise ValueError(f"sigma_knots[{j}] must be a pair (time in 1/r_min, sigma); got {knot!r}")
            t = check_real(
                f"sigma step time #{j + 1} (in units of 1/r_min)", knot[0], lo=last, lo_open=True, hi=TIME_MAX
            )
            s = check_real(f"sigma after step #{j + 1}", knot[1], lo=SIGMA_BOUNDS[0], hi=SIGMA_BOUNDS[1])
            knots.append((t, s))
            last = t
        object.__setattr__(self, "sigma_knots", tuple(knots))
        _choice("sigma_shape", self.sigma_shape, SIGMA_SHAPES)
        _choice("noise", self.noise, NOISE_LAWS)
        object.__setattr__(
            self,
            "dof",
            check_real("dof (degrees of freedom of the Student-t noise)", self.dof, lo=2.0, lo_open=True, hi=DOF_MAX),
        )
        object.__setattr__(
            self, "outlier_rate", check_real("outlier_rate", self.outlier_rate, lo=0.0, hi=1.0, hi_open=True)
        )
        object.__setattr__(
            self, "outlier_scale", check_real("outlier_scale", self.outlier_scale, lo=1.0, hi=OUTLIER_SCALE_MAX)
        )
        object.__setattr__(
            self,
            "sensor_interval",
            check_real("sensor_interval (in units of 1/r_min)", self.sensor_interval, lo=0.0, hi=TIME_MAX),
        )

    @property
    def is_default(self) -> bool:
        """Paper A's model: σ constant, Gaussian noise, the sensor read at every step."""
        return not self.sigma_knots and self.noise == "gaussian" and self.sensor_interval == 0.0

    @property
    def noise_variance(self) -> float:
        """E ε_k² of the noise law (1 but for outliers: 1 − p + p·k²)."""
        if self.noise == "outliers":
            return 1.0 - self.outlier_rate + self.outlier_rate * self.outlier_scale**2
        return 1.0

    def sigma_at(self, sigma0: float, t: np.ndarray) -> np.ndarray:
        """σ at times ``t`` (units of 1/r_min), σ(0) = ``sigma0``."""
        t = np.asarray(t, dtype=float)
        if not self.sigma_knots:
            return np.full(t.shape, float(sigma0))
        times = np.array([0.0] + [k[0] for k in self.sigma_knots])
        values = np.array([float(sigma0)] + [k[1] for k in self.sigma_knots])
        if self.sigma_shape == "steps":  # the values themselves, not exp(log(σ)): a step is σ_j exactly
            return values[np.searchsorted(times, t, side="right") - 1]
        return cast("np.ndarray", np.exp(np.interp(t, times, np.log(values))))

    def sigma_constant_on(self, t0: float, t1: float) -> bool:
        """Whether σ(t) is one value for all t in [t0, t1] (units of 1/r_min)."""
        if self.sigma_shape == "drift":
            return not self.sigma_knots or t0 >= self.sigma_knots[-1][0]
        return not any(t0 < t <= t1 for t, _ in self.sigma_knots)

    def sensor_steps(self, h: float, r_min: float) -> int:
        """q: grid steps per sensor reading (≥ 1)."""
        return max(1, round(self.sensor_interval / (r_min * h))) if self.sensor_interval > 0.0 else 1

    def draw_noise(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """ε_0 … ε_{n−1} of the noise law, from ``rng``, as the scenario loop draws them (:mod:`!isl_core.noise`)."""
        eps = np.empty(n)
        fill(rng, self.noise_law(), eps)
        return eps

    def noise_law(self) -> NoiseLaw:
        """The noise law as the compiled loops take it (:class:`!isl_core.kernels.bundles.NoiseLaw`)."""
        return NoiseLaw(
            LAWS[self.noise],
            self.dof,
            law_table(self.noise, self.dof),
            self.outlier_rate,
            self.outlier_scale,
            self.noise_variance,
        )


def sigma_path(scenario: Scenario, model: Model, r_min: float, h: float, n: int) -> np.ndarray:
    """σ_k = σ(t_k), k = 0 … n − 1, on the grid t_k = k·h (σ(0) = ``model.sigma``; times scaled by ``r_min``)."""
    return scenario.sigma_at(model.sigma, np.arange(n) * (h * r_min))


@dataclass(frozen=True)
class Clairvoyant:
    """The clairvoyant filter of one scenario on one grid: its gains and its exact error variances.

    ``gain[k]`` (n, m) multiplies the innovation taken in at step k → k+1 (zero between sensor readings);
    ``var[k]`` (n + 1, m) is the diagonal of P_k, the covariance of its error at t_k; ``q`` the sensor steps.
    """

    gain: np.ndarray
    var: np.ndarray
    q: int


def clairvoyant(model: Model, scenario: Scenario, h: float, n: int) -> Clairvoyant:
    """The clairvoyant filter's gains and error variances for ``n`` steps of size ``h`` (module docstring).

    Parameters
    ----------
    model : Model
        The model at σ(0).
    scenario : Scenario
        What the world does.
    h : float
        The step.
    n : int
        The number of steps.

    Returns
    -------
    Clairvoyant
        ``gain`` (n, m) per step, ``var`` (n + 1, m) the exact error variances P_ii, ``q`` the steps per reading.

    Examples
    --------
    >>> import numpy as np
    >>> from isl_core import Model, Scenario, clairvoyant
    >>> ref = clairvoyant(Model.from_w(0.5, 3.0, 20.0), Scenario(), 0.01, 100)
    >>> ref.gain.shape, ref.var.shape, bool(np.all(ref.var > 0))
    ((100, 3), (101, 3), True)
    """
    kb = kalman_bucy(model)
    sigmas = sigma_path(scenario, model, kb.r_min, h, n)
    gain, var = np.zeros((n, model.m)), np.zeros((n + 1, model.m))
    q = scenario.sensor_steps(h, kb.r_min)
    riccati_path(
        clairvoyant_state(np.array(kb.delta, dtype=float), q),
        float(h),
        model.alpha,
        model.beta**2,
        h * sigmas**2 * scenario.noise_variance,
        q,
        gain,
        var,
    )
    return Clairvoyant(gain, var, q)
