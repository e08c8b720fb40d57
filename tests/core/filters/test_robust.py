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


def _moment(c: float, p: int = 2) -> float:
    """E min(|Z|, c)^p by quadrature (the module computes κ(c), p = 2, in closed form)."""
    z = np.linspace(-12.0, 12.0, 480_001)
    return float(np.trapezoid(np.minimum(np.abs(z), c) ** p * np.exp(-0.5 * z * z), z) / math.sqrt(2.0 * math.pi))


def _kappa(c: float) -> float:
    """E min(Z², c²) by quadrature."""
    return _moment(c, 2)


def test_hubers_kappa_and_the_robust_filters_sigma_on_gaussian_noise():
    assert huber_kappa(1.345) == pytest.approx(_kappa(1.345), rel=1e-9)
    assert huber_kappa(10.0) == pytest.approx(1.0, abs=1e-12)
    # on Gaussian noise the clipped, κ-corrected variance estimate is consistent: σ̂ ≈ σ like the adaptive filter's
    run = simulate_scenario(
        MODEL, 3.0, Scenario(), horizon=200.0, windows=10, seed=4, extra=[adaptive_kbf(MODEL), robust_kbf(MODEL)]
    )
    late = run.sigma_hat[2:].mean(axis=0)
    # the mean of σ̂ over L readings is as good as the plain mean of L terms ψ²/κ: relative sd ½·√(Var/L), with
    # Var = Var(u²)/σ⁴ = 2 (adaptive) and Var min(Z², c²)/κ² (robust), both within five sd of σ
    readings = int(run.steps[2:].sum())
    c = robust_kbf(MODEL).huber
    kappa = huber_kappa(c)
    spread = np.array([2.0, (_moment(c, 4) - kappa**2) / kappa**2])
    assert np.all(np.abs(late / MODEL.sigma - 1.0) <= 5.0 * 0.5 * np.sqrt(spread / readings)), (late, readings)
