"""The ISL filters: paper A's (A.16–A.18), propagating with A0, and the model-aware one, propagating with the true A.

    Ž ← (I + h·(A0 − a·E Eᵀ))·Ž + √h·φ(u),   φ_i(u) = c_i sign(u)|u|^{1−i/m},   c_i ∝ ν^{i/m}      (A.17–A.18)

with the innovation u = ΔY/√h − √h·Ž_1 and the power law of :mod:`isl_core.nonlinearity`. Paper A's filter takes
a = 0 (A0: it does not use α); the model-aware one a = α (:func:`model_aware_isl`), so that at α = 0 the two are the
same filter, bit for bit.
"""

from __future__ import annotations

import dataclasses

from ..bounds import BOUNDS
from ..model import Model
from ..nonlinearity import gains_at
from .base import FilterSpec

__all__ = ["isl_filter", "model_aware_isl"]


def isl_filter(model: Model, nu: float) -> FilterSpec:
    """Paper A's ISL filter (A.16–A.18): power-law φ tuned by ν, propagation with A0.

    Parameters
    ----------
    model : Model
        The model the filter runs on (its β, m; the filter propagates with A0, whatever α).
    nu : float
        The tuning ν > 0 of the power law (paper A's table (A.31) gives ν/β per α).

    Returns
    -------
    FilterSpec
        The filter, named ``"isl"``, for :func:`isl_core.simulate` (``extra=``) or :func:`isl_core.simulate_rmse`.

    Examples
    --------
    >>> from isl_core import Model, isl_filter
    >>> model = Model.from_w(0.5, 3.0, 20.0)
    >>> spec = isl_filter(model, nu=model.beta)
    >>> spec.name, spec.coef.shape
    ('isl', (3,))
    """
    nu = BOUNDS.nu.real(nu)  # the filter's one check of ν; m is its model's, checked when the model was made
    return FilterSpec("isl", f"ISL (ν = {nu:.4g})", 0.0, gains_at(model.m, nu), True)


def model_aware_isl(model: Model, nu: float) -> FilterSpec:
    """ISL filter with paper A's φ (A.17) that propagates with the true A = A0 − αEEᵀ (damp = α)."""
    spec = isl_filter(model, nu)  # validates nu
    return dataclasses.replace(spec, name="isl_model", label=f"ISL model-aware (ν = {float(nu):.4g})", damp=model.alpha)
