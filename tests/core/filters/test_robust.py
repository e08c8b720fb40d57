"""The robust adaptive filter (Huber's ψ on the innovations): κ(c) and its σ̂ on Gaussian noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isl_core import Model, adaptive_kbf
from isl_core.filters.robust import huber_kappa, robust_kbf
from isl_core.scenario import Scenario
from isl_core.scenario.run import simulate_scenario

MODEL = Model.from_w(alpha=0.5, w=3.0, sigma=20.0, m=3)  # paper A's Fig. 3


def _kappa(c: float) -> float:
    """E min(Z², c²) by quadrature (the module computes it in closed form)."""
    z = np.linspace(-12.0, 12.0, 480_001)
    return float(np.trapezoid(np.minimum(z * z, c * c) * np.exp(-0.5 * z * z), z) / math.sqrt(2.0 * math.pi))


def test_hubers_kappa_and_the_robust_filters_sigma_on_gaussian_noise():
    assert huber_kappa(1.345) == pytest.approx(_kappa(1.345), rel=1e-9)
    assert huber_kappa(10.0) == pytest.approx(1.0, abs=1e-12)
    # on Gaussian noise the clipped, κ-corrected variance estimate is consistent: σ̂ ≈ σ like the adaptive filter's
    run = simulate_scenario(
        MODEL, 3.0, Scenario(), horizon=200.0, windows=10, seed=4, extra=[adaptive_kbf(MODEL), robust_kbf(MODEL)]
    )
    late = run.sigma_hat[2:].mean(axis=0)
    assert late == pytest.approx([MODEL.sigma, MODEL.sigma], rel=0.02)
