"""The interacting-multiple-model (IMM) filter: a bank of Kalman filters over a grid of σ, mixed by a Markov chain.

H. A. P. Blom and Y. Bar-Shalom, "The interacting multiple model algorithm for systems with Markovian switching
coefficients", IEEE Trans. Automatic Control 33(8):780–783, 1988. The textbook answer to an observation noise whose
intensity switches: J mode-matched Kalman filters, mode j assuming σ = σ_j, of the model it knows (α, β, m: the
same A as the clairvoyant filter, :mod:`isl_core.scenario`), and the probabilities μ_j of the modes, which switch
by a Markov chain with probability p per sensor reading — staying with 1 − p, moving to each other mode with
p/(J − 1). It does not know σ(t). Per reading (the increment of Y over the q steps since the last one, B.34):

    mixing      c̄_j = Σ_i p_ij μ_i,   μ_i|j = p_ij μ_i / c̄_j                           (Blom & Bar-Shalom, (6)–(7))
                Ẑ0_j = Σ_i μ_i|j Ẑ_i,   P0_j = Σ_i μ_i|j [P_i + (Ẑ_i − Ẑ0_j)(Ẑ_i − Ẑ0_j)ᵀ]
    mode j      the clairvoyant filter's recursion with σ_k ≡ σ_j from (Ẑ0_j, P0_j): per step the prediction
                P ← F_a P F_aᵀ + h β² E Eᵀ on the state (X, S), S = h Σ C X over the interval; at the reading
                the innovation r_j = ΔY − h Σ C Ẑ_j, s_j = C_a P Cᵀ_a + q h σ_j², gain P C_aᵀ / s_j
    likelihood  Λ_j = N(r_j; 0, s_j),   μ_j = Λ_j c̄_j / Σ_l Λ_l c̄_l                      ((8)–(9))
    output      Ẑ = Σ_j μ_j Ẑ_j                                                       ((10))

The mixing is done on the predicted estimates at the start of each sensor interval, which is the paper's mixing of
the filtered ones followed by the prediction: every mode has the same F, so mixing and predicting commute (the
spread term included). Each mode is then exactly the clairvoyant Kalman filter of the grid (:func:`clairvoyant`)
with σ_j: with one mode at the true constant σ the IMM filter is that Kalman filter, step for step.

**Error coordinates**, as every filter of the scenario loop (:mod:`isl_core.kernels.scenario`): the
bank carries e_j = Ẑ_j − X, whose innovation ΔY − h Σ C Ẑ_j = √h·Σ(σ_k ε_k − √h e_j,1) depends on the errors only.
Since Σ_i μ_i|j = 1 the mixing of estimates is the same mixing of errors (Ẑ_i − Ẑ0_j = e_i − e0_j), and the
filter's error is Σ_j μ_j e_j. Between readings the modes only propagate, like the combined error; at a reading
the bank hands the scenario loop the combined error's correction (:func:`isl_core.kernels.imm.imm_step`).

The weights are computed as c̄_j s_j^(−1/2) exp(−(r_j²/2s_j − min_l r_l²/2s_l)): the exponents shifted by the
smallest (the log-sum-exp guard), so the best-fitting mode's factor is 1 and a reading far out for every mode (a
σ grid far from the truth) does not underflow them all to 0/0; c̄_j ≥ min(1 − p, p/(J − 1)) > 0.

**Knobs**: the grid of σ (``modes`` log-spaced values over ``sigma_range``; default 11 over [1.5, 500], spaced
×1.79, none equal to a preset's σ) and the switch probability per reading ``switch`` (memory in readings, as the
σ-learners': :mod:`isl_core.filters.adaptive`). It starts as after a mixing: every mode at the common start e₀ with the
stationary covariance Δ of its σ_j (A.23), weights 1/J. Its σ̂ (for the pictures) is Σ_j μ_j σ_j.
Symbols: J = ``modes``, p = ``switch``, σ_j = ``IMMBank.sigmas``.
"""

from __future__ import annotations

import numpy as np

from ..model import Model
from ..riccati import kalman_bucy
from ..validate import check_int, check_real, check_sigma_range
from .adaptive import sigma_limit
from .base import FilterSpec, IMMBank

__all__ = ["IMM_GRID_RANGE", "MODES", "SWITCH", "imm_kbf"]

IMM_GRID_RANGE = (1.5, 500.0)  #: the default σ grid's ends: wider than the presets' σ, none of its points equal to one
MODES = 11  #: default number of modes (grid density: ×1.79 apart over the default range)
SWITCH = 1e-2  #: default switch probability per reading
MODES_MAX = 64
SWITCH_MIN = 1e-12  #: keeps every prior weight c̄_j ≥ p/(J − 1) far from the float range's end


def imm_kbf(
    model: Model, *, sigma_range: tuple[float, float] = IMM_GRID_RANGE, modes: int = MODES, switch: float = SWITCH
) -> FilterSpec:
    """The IMM filter (module docstring) for ``model``'s α, β, m (σ is not used): ``modes`` σ_j log-spaced over
    ``sigma_range`` (its ends included), switch probability ``switch`` per reading (10⁻¹² ≤ p < 1).

    Parameters
    ----------
    model : Model
        The model (its α, β, m).
    sigma_range : (float, float)
        The modes' σ range.
    modes : int
        The number of modes J.
    switch : float
        The switch probability p per reading.

    Returns
    -------
    FilterSpec
        The filter, named ``"imm"``, its bank in ``imm``.

    Examples
    --------
    >>> from isl_core import imm_kbf
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> spec = imm_kbf(model, modes=6)
    >>> spec.name, len(spec.imm.sigmas)
    ('imm', 6)
    """
    if not isinstance(model, Model):
        raise ValueError(f"model must be an isl_core.Model, got {type(model).__name__}")
    lo, hi = check_sigma_range(sigma_range)
    modes = check_int("modes (the number of σ values of the IMM bank)", modes, lo=1, hi=MODES_MAX)
    switch = check_real("switch (probability per reading)", switch, lo=SWITCH_MIN, hi=1.0, hi_open=True)
    if hi > sigma_limit(model):
        raise ValueError(f"sigma_range must end at or below {sigma_limit(model):.4g} for this model, got {hi:g}")
    if modes > 1 and not hi > lo:
        raise ValueError(f"sigma_range must have sigma_max > sigma_min for {modes} modes, got ({lo:g}, {hi:g})")
    sigmas = np.geomspace(lo, hi, modes) if modes > 1 else np.array([lo])
    if modes > 1:
        sigmas[0], sigmas[-1] = lo, hi
    cov = np.array([kalman_bucy(Model(model.alpha, model.beta, float(s), model.m)).delta for s in sigmas])
    bank = IMMBank(sigmas, float(switch), cov)
    span = f"σ = {lo:g}" if modes == 1 else f"{modes} σ modes over [{lo:g}, {hi:g}]"
    return FilterSpec(
        "imm", f"IMM ({span}, switch {switch:g} a reading)", model.alpha, np.zeros(model.m), False, imm=bank
    )
