"""The grid of a run (isl_core.grid, :ref:`step-size`): ``settling_rate``, ``run_plan`` and the scenarios'
``scenario_grid``, against the rules written out here with scipy and the papers' formulas (tests/_reference.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _reference import care, gamma_abs, isl_coefficients

from isl_core import Model, Scenario, isl_filter, kalman_bucy, run_plan, scenario_grid, settling_rate
from isl_core.grid import H_RATE, SETTLE_TOL

FIG3 = Model.from_w(0.5, 3.0, 20.0, 3)  # paper A, Fig. 3


def _isl_rate(model: Model, nu: float) -> float:
    """−max Re λ(Λ) of the ISL filter, Λ = A0 − σ⁻²LCᵀ with L_i = c_i γ_{1+q_i} σ^{1+q_i} (B.40, B.46)."""
    m = model.m
    q = 1.0 - np.arange(1, m + 1) / m
    L = isl_coefficients(m, nu) * np.array([gamma_abs(1.0 + qi) for qi in q]) * model.sigma ** (1.0 + q)
    lam = np.eye(m, k=1) - np.outer(L, np.eye(m)[0]) / model.sigma**2
    return float(-np.linalg.eigvals(lam).real.max())


def _r_min(model: Model) -> float:
    delta = care(model.alpha, model.beta, model.sigma, model.m)
    closed = model.A - np.outer(delta[:, 0] / model.sigma**2, model.C[0])
    return float(-np.linalg.eigvals(closed).real.max())


@pytest.mark.parametrize("ell", [-6.0, -3.0, 0.0])
def test_settling_rate_is_the_slowest_filters_unless_within_the_tolerance(ell):
    nu = FIG3.beta * 2.0**ell
    kb = kalman_bucy(FIG3)
    r_min, isl = _r_min(FIG3), _isl_rate(FIG3, nu)
    assert kb.r_min == pytest.approx(r_min, rel=1e-9)
    expected = kb.r_min if isl * SETTLE_TOL >= kb.r_min else isl
    assert settling_rate(FIG3, kb, [isl_filter(FIG3, nu)]) == pytest.approx(expected, rel=1e-9)
    assert settling_rate(FIG3, kb, []) == kb.r_min


def test_settling_rate_sees_a_slow_filter_at_small_nu():
    """ν = β/64 settles far slower than the optimal filter: that rate, not r_min (the case above that can fail)."""
    kb = kalman_bucy(FIG3)
    rate = settling_rate(FIG3, kb, [isl_filter(FIG3, FIG3.beta / 64)])
    assert rate < kb.r_min / SETTLE_TOL
    assert rate == pytest.approx(_isl_rate(FIG3, FIG3.beta / 64), rel=1e-9)


@pytest.mark.parametrize("model", [FIG3, Model(0.0, 1.0, 5.0, 1), Model.from_w(5.0, 3.0, 200.0, 3)])
def test_run_plan_spans_the_horizon_on_a_grid_within_the_rate_margin(model):
    nu = model.beta
    plan = run_plan(model, nu, horizon=10.0)
    r_min = _r_min(model)
    stretch = max(1.0, r_min / _isl_rate(model, nu)) if _isl_rate(model, nu) * SETTLE_TOL < r_min else 1.0
    assert plan.stretch == pytest.approx(stretch, rel=1e-9)
    assert pytest.approx(10.0 * stretch / r_min, rel=1e-9) == plan.T and plan.horizon == pytest.approx(10.0 * stretch)
    assert math.ceil(plan.T / plan.h - 1e-9) == plan.N and plan.N * plan.h == pytest.approx(plan.T, rel=1e-12)
    delta = care(model.alpha, model.beta, model.sigma, model.m)
    closed = model.A - np.outer(delta[:, 0] / model.sigma**2, model.C[0])
    fastest = max(np.abs(np.linalg.eigvals(closed)).max(), model.alpha, r_min)
    assert plan.h <= H_RATE / fastest * (1 + 1e-12)  # (B.47) with the margin, and shrunk further only


def test_run_plan_with_t_given_is_not_stretched_and_refuses_past_its_cap():
    plan = run_plan(FIG3, FIG3.beta / 64, T=3.0)
    assert plan.stretch == 1.0 and plan.T == 3.0 and plan.N * plan.h == pytest.approx(3.0, rel=1e-12)
    with pytest.raises(ValueError, match=r"\bT\b.*\bh\b|\bh\b.*\bT\b"):
        run_plan(FIG3, FIG3.beta, T=3.0, cap=10)


def test_scenario_grid_takes_the_finest_step_over_sigmas_range():
    """σ 20 → 2 at 2/r_min: the step is the finer of the two σ's grids, the run exactly horizon/r_min at σ(0)."""
    scenario = Scenario(sigma_knots=((2.0, 2.0),))
    h, n, r_min = scenario_grid(FIG3, FIG3.beta, scenario, (), 10.0)
    assert r_min == pytest.approx(_r_min(FIG3), rel=1e-9)
    assert n * h == pytest.approx(10.0 / r_min, rel=1e-12)
    low = Model(FIG3.alpha, FIG3.beta, 2.0, FIG3.m)
    finest = min(run_plan(m, FIG3.beta, T=10.0 / r_min).h for m in (FIG3, low))
    assert h <= finest * (1 + 1e-12) and n == math.ceil(10.0 / r_min / finest - 1e-9)
    with pytest.raises(ValueError, match=r"^horizon = 500000 needs [\d,]+ steps"):  # under run_plan's cap, over its own
        scenario_grid(FIG3, FIG3.beta, scenario, (), 5e5)
