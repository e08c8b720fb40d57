"""Scenario runs (isl_core.scenario.run, isl_core.kernels.scenario): an independent loop, today's runs, the
reference."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isl_core import Model, adaptive_kbf, simulate
from isl_core.filters.robust import robust_kbf
from isl_core.filters.variational import variational_kbf
from isl_core.scenario import Scenario, clairvoyant, sigma_path
from isl_core.scenario.run import plan_scenario, simulate_scenario

MODEL = Model.from_w(alpha=0.5, w=3.0, sigma=20.0, m=3)  # paper A's Fig. 3


def test_the_constant_gaussian_scenario_gives_todays_run_bit_for_bit():
    """One window per step: each window holds one step's squared error, which must be today's, bit for bit — the
    same grid, the same draws and the same arithmetic at every step; only the RMSE's sum is grouped differently."""
    today = simulate(MODEL, 3.0, horizon=20.0, seed=3)
    n = len(today.t) - 1
    run = simulate_scenario(MODEL, 3.0, Scenario(), horizon=20.0, windows=n, seed=3)
    assert (run.h, run.N) == (today.h, n) and np.all(run.steps == 1)
    for f, track in ((1, today.tracks[0]), (2, today.tracks[1])):  # Kalman–Bucy for σ(0), ISL
        np.testing.assert_array_equal(run.mse[:, f, :], track.error[1:] ** 2)
    rmse = np.sqrt(np.tensordot(run.steps.astype(float), run.mse, axes=1) / run.N)
    assert np.allclose(rmse[2], today.tracks[1].rmse, rtol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize(
    "scenario",
    [
        Scenario(),
        Scenario(sigma_knots=((10.0, 2.0),)),
        Scenario(sigma_knots=((10.0, 200.0),), noise="student", dof=3.0),
        Scenario(noise="outliers", sensor_interval=0.1),
    ],
)
def test_the_clairvoyant_filters_error_matches_its_own_covariance_on_long_runs(scenario):
    run = simulate_scenario(MODEL, 3.0, scenario, horizon=4000.0, windows=100, seed=1)
    # per window of 40/r_min at σ(0) (many settling times, so nearly independent batches): MSE / mean P ≈ 1. (Pooled
    # over the run, the windows of the largest σ would dominate: one window's sampling error, not a check.)
    per_window = run.mse[:, 0, :] / run.ref_var
    mean = per_window.mean(axis=0)
    se = per_window.std(axis=0, ddof=1) / math.sqrt(len(per_window))
    assert np.all(np.abs(mean - 1.0) < 4.0 * se), (mean, se)
    assert np.all(se < 0.04)  # a check that can fail: the interval is narrow


def test_a_filter_that_diverges_is_stopped_and_marked_while_the_others_go_on():
    # a sensor read every 3/r_min: the Kalman–Bucy gain for continuous observation, applied to one reading of
    # 3/r_min at once, overshoots and the error grows ≈ 15-fold a reading until it leaves the float range; the
    # clairvoyant filter is the exact Kalman filter of that coarse sensor and stays finite
    run = simulate_scenario(MODEL, 3.0, Scenario(sensor_interval=3.0), horizon=1200.0, windows=12, seed=2)
    kbf = run.names.index("kbf")
    assert run.diverged[0] is None and run.diverged[kbf] is not None
    first = int(np.argmax(np.isinf(run.mse[:, kbf, 0])))
    assert np.all(np.isinf(run.mse[first:, kbf])) and np.all(np.isfinite(run.mse[:first, kbf]))
    assert np.all(np.isfinite(run.mse[:, 0])) and np.all(run.ratios()[:, 0] < 3.0)


@pytest.mark.parametrize(
    ("scenario", "horizon"),
    [
        (Scenario(sigma_knots=((0.2, 2.0), (0.4, 50.0))), 0.8),
        (Scenario(sigma_knots=((0.3, 200.0),), sigma_shape="drift"), 0.8),
        (Scenario(sensor_interval=0.03), 0.8),
        (Scenario(sigma_knots=((25.0, 2.0),), sensor_interval=0.05), 30.0),  # the sensor cycle settles, then σ steps
    ],
)
def test_the_runs_windows_hold_the_clairvoyant_variance_and_sigma_of_their_steps(scenario, horizon):
    """The run's loop carries the clairvoyant recursion in line and sums P_ii and σ_k per window, once per stretch
    where both repeat (or reads a settled sensor cycle back): the same, per window, as the whole recursion
    (clairvoyant) and σ path summed step by step."""
    run = simulate_scenario(MODEL, 3.0, scenario, horizon=horizon, windows=7, seed=2)
    ref = clairvoyant(MODEL, scenario, run.h, run.N)
    edges = np.concatenate([[0], np.cumsum(run.steps)])
    var = np.add.reduceat(ref.var[1:], edges[:-1], axis=0) / run.steps[:, None]
    sig = np.add.reduceat(sigma_path(scenario, MODEL, run.r_min, run.h, run.N), edges[:-1]) / run.steps
    np.testing.assert_allclose(run.ref_var, var, rtol=1e-12)
    np.testing.assert_allclose(run.sigma, sig, rtol=1e-12)


@pytest.mark.parametrize(
    "scenario", [Scenario(noise="student"), Scenario(sigma_knots=((0.3, 2.0),), sensor_interval=0.03)]
)
def test_a_plan_runs_any_seed_as_simulate_scenario_does_and_is_not_changed_by_its_runs(scenario):
    """average_scenario sets a scenario up once (plan_scenario) and runs it per seed: every run must be the one
    simulate_scenario gives for that seed, whichever runs came before (a run that wrote into the plan's arrays, the
    σ-learning filters' state or the clairvoyant start, would change the next)."""
    extra = [variational_kbf(MODEL, sigma_init=40.0), robust_kbf(MODEL, sigma_init=40.0)]
    plan = plan_scenario(MODEL, 3.0, scenario, horizon=0.6, windows=5, extra=extra)
    for seed in (3, 1, 3):
        run, alone = (
            plan.run(seed),
            simulate_scenario(MODEL, 3.0, scenario, horizon=0.6, windows=5, seed=seed, extra=extra),
        )
        np.testing.assert_array_equal(run.mse, alone.mse)
        np.testing.assert_array_equal(run.sigma_hat, alone.sigma_hat)
        np.testing.assert_array_equal(run.ref_var, alone.ref_var)


def test_memory_counts_readings_and_its_time_is_readings_times_the_sensor_interval():
    """W readings of a sensor read every Δ are W·Δ in time (q = round(Δ/h) steps: within half a step a reading); with
    a reading at every step, W·h."""
    coarse = plan_scenario(MODEL, 3.0, Scenario(sensor_interval=0.1), horizon=1.0, windows=1)
    assert coarse.memory_time(30.0) == pytest.approx(30.0 * 0.1, rel=0.5 / coarse.q)
    fine = plan_scenario(MODEL, 3.0, Scenario(), horizon=1.0, windows=1)
    assert fine.q == 1 and fine.memory_time(30.0) == pytest.approx(30.0 * fine.h * fine.r_min, rel=1e-15)
    assert "W = 30 readings" in adaptive_kbf(MODEL, memory=30.0).label
    assert "W = 30 readings" in variational_kbf(MODEL, memory=30.0).label
    with pytest.raises(ValueError, match=r"memory \(W, in sensor readings\) must be a finite number > 1"):
        variational_kbf(MODEL, memory=1.0)


def test_a_window_that_starts_at_a_change_of_sigma_holds_exactly_the_steps_after_it():
    """Windows start at the first step whose σ_k is the new σ: the clairvoyant variance of the window before the change
    is that of σ(0) alone, and explicit edges give windows between them."""
    change = 0.37
    plan = plan_scenario(MODEL, 3.0, Scenario(sigma_knots=((change, 2.0),)), horizon=1.0, edges=(0.0, change, 1.0))
    k = int(plan.edges[1])
    assert len(plan.edges) == 3 and (k - 1) * plan.h * plan.r_min < change <= k * plan.h * plan.r_min
    run = plan.run(0)
    assert np.all(run.sigma[:1] == MODEL.sigma) and np.all(run.sigma[1:] == 2.0)
    with pytest.raises(ValueError, match="edges must increase from 0 to the horizon"):
        plan_scenario(MODEL, 3.0, horizon=1.0, edges=(0.0, 0.5, 0.4, 1.0))
