"""The filters a user who does not know σ could run instead of the ISL filter — interchangeable parts of one run.

Each is a :class:`isl_core.FilterSpec` for the fused kernel, so any set of them rides on one trajectory
(common random numbers, :func:`isl_core.simulate` ``extra=`` or :func:`isl_core.simulate_rmse`). Stable names:

============== ================================================================== ==================================
name           filter                                                             theory, :func:`isl_core.theory_ratios`
============== ================================================================== ==================================
kbf            Kalman–Bucy with the true σ (A.21–A.24): the oracle                 1 (Δ itself)
isl            paper A's ISL filter, tuning ν, propagation with A0 (A.16–A.18)    :ref:`linearized-covariance`
kbf_mismatched Kalman–Bucy with the gain K̄ of the CARE for a guessed σ̄           Lyapunov (:ref:`mismatched-kbf`)
kbf_minimax    Kalman–Bucy designed for the top of the σ range, σ̄ = σ_max         Lyapunov (:ref:`minimax-kbf`)
kbf_adaptive   Kalman–Bucy, σ̂ learned online (:mod:`isl_core.filters.adaptive`)  none (nan)
isl_model      model-aware ISL: the same φ, propagation with A = A0 − αEEᵀ         :ref:`linearized-covariance` with A
============== ================================================================== ==================================

The mismatched filter's default guess is the geometric middle ``σ̄ = √(σ_min σ_max)`` of the σ range: the
design that sits the same factor away from both ends, and — for the Fig. 2 models (m = 3, w = 3) — the
σ̄ that minimises the predicted worst-case ratio over the range to within the grid of
:func:`isl_core.recommend.best_fixed_kbf`. The "minimax" filter is the conservative engineering design
"assume the largest noise"; it is far from the minimax over fixed gains (its gain is too small at σ_min).

Fixed-gain Kalman–Bucy filters are linear, so their Lyapunov equation
``(A − K̄C)P + P(A − K̄C)ᵀ + β²EEᵀ + σ²K̄K̄ᵀ = 0`` is exact (in continuous time; the Euler grid adds O(h·rate)).
With α = 0 the model-aware ISL filter is paper A's filter, bit for bit (damp = α = 0).
"""

from __future__ import annotations

from collections.abc import Sequence

from ..model import Model
from ..riccati import kalman_bucy
from ..validate import check_sigma_range, short
from .adaptive import MEMORY, adaptive_kbf
from .base import SIGMA_RANGE, FilterSpec
from .isl import isl_filter, model_aware_isl
from .kalman import design_sigma, minimax_kbf, mismatched_kbf, optimal_kbf

__all__ = ["BASELINES", "LABELS", "baseline_filters", "check_names"]

#: stable names of the filters, in the order tables list them
BASELINES = ("kbf", "isl", "kbf_mismatched", "kbf_minimax", "kbf_adaptive", "isl_model")

#: short human labels (table columns, legends); a spec's own ``label`` adds its parameters
LABELS = {
    "kbf": "KBF oracle (knows σ)",
    "isl": "ISL (paper A)",
    "kbf_mismatched": "KBF for mid σ",
    "kbf_minimax": "KBF for max σ",
    "kbf_adaptive": "KBF adaptive",
    "isl_model": "ISL model-aware",
}


def baseline_filters(
    model: Model,
    *,
    nu: float,
    nu_model: float | None = None,
    sigma_design: float | None = None,
    sigma_range: tuple[float, float] = SIGMA_RANGE,
    memory: float = MEMORY,
    names: Sequence[str] = BASELINES,
) -> list[FilterSpec]:
    """The filters ``names`` (default all of :data:`BASELINES`, in that order) for ``model``.

    ``nu``: the ISL filter's tuning; ``nu_model``: the model-aware ISL filter's (default ``nu``);
    ``sigma_design``: σ̄ of the mismatched filter (default :func:`!design_sigma` of ``sigma_range``);
    ``sigma_range``: also the top for ``kbf_minimax`` and the adaptive filter's table and start;
    ``memory``: the adaptive filter's memory W in readings (here every step is a reading).

    Parameters
    ----------
    model : Model
        The model.
    nu, nu_model : float
        The ISL filter's and the model-aware ISL filter's tunings.
    sigma_design : float, optional
        σ̄ of the mismatched filter.
    sigma_range : (float, float)
        The σ range.
    memory : float
        The adaptive filter's W in readings.
    names : sequence of str
        The filters (default :data:`BASELINES`).

    Returns
    -------
    list of FilterSpec
        One filter per name, in the order of ``names``.

    Examples
    --------
    >>> from isl_core import BASELINES, baseline_filters
    >>> from isl_core import Model
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> tuple(spec.name for spec in baseline_filters(model, nu=model.beta)) == BASELINES
    True
    >>> [spec.name for spec in baseline_filters(model, nu=model.beta, names=["kbf", "kbf_adaptive"])]
    ['kbf', 'kbf_adaptive']
    """
    if not isinstance(model, Model):
        raise ValueError(f"model must be an isl_core.Model, got {type(model).__name__}")
    names = check_names(names)
    check_sigma_range(sigma_range)
    makers = {
        "kbf": lambda: optimal_kbf(model, kalman_bucy(model)),
        "isl": lambda: isl_filter(model, nu),
        "kbf_mismatched": lambda: mismatched_kbf(
            model, design_sigma(sigma_range) if sigma_design is None else sigma_design
        ),
        "kbf_minimax": lambda: minimax_kbf(model, sigma_range),
        "kbf_adaptive": lambda: adaptive_kbf(model, sigma_range=sigma_range, memory=memory),
        "isl_model": lambda: model_aware_isl(model, nu if nu_model is None else nu_model),
    }
    return [makers[name]() for name in names]


def check_names(names: object, param: str = "names", allowed: Sequence[str] = BASELINES) -> tuple[str, ...]:
    """``names`` as a non-empty tuple of distinct names of ``allowed``, or a ``ValueError`` naming ``param``."""
    what = f"{param} must be a non-empty sequence of distinct names from {list(allowed)}"
    if not isinstance(names, list | tuple):
        raise ValueError(f"{what}, got {short(names)}")
    names = tuple(names)
    if not (names and all(isinstance(n, str) and n in allowed for n in names) and len(set(names)) == len(names)):
        raise ValueError(f"{what}, got {short(names)}")
    return names
