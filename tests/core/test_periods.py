"""The period statistic (isl_core.scenario.periods): fixed periods, pooled over seeds; the clairvoyant filter reads 1 on
it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from isl_core import Model, Scenario, average_scenario
from isl_core.filters.adaptive import adaptive_kbf
from isl_core.scenario.periods import edge_times, paired_margin, ratios_from, scenario_periods

MODEL = Model.from_w(1.0, 3.0, 20.0, 3)
DROP = Scenario(sigma_knots=((3.0, 2.0),))
SEEDS = 24


def _average(scenario, horizon=8.0, **kwargs):
    periods = scenario_periods(scenario, horizon)
    avg = average_scenario(
        MODEL, 3.0, scenario, seeds=range(SEEDS), horizon=horizon, extra=[adaptive_kbf(MODEL, memory=30.0)], **kwargs
    )
    return periods, avg


@pytest.fixture(scope="module")
def drop():
    periods, avg = _average(DROP, edges=edge_times(scenario_periods(DROP, 8.0), 8.0))
    return periods, avg, avg.periods()


def test_the_periods_of_a_change_and_of_a_constant_scenario():
    change = scenario_periods(Scenario(sigma_knots=((10.0, 2.0),)), 30.0)
    assert [(p.name, p.start, p.end) for p in change] == [
        ("after_1", 10.0, 11.0),
        ("after_2", 10.0, 12.0),
        ("settled", 12.0, 30.0),
    ]
    assert [(p.name, p.start, p.end) for p in scenario_periods(Scenario(noise="student"), 30.0)] == [
        ("settled", 2.0, 30.0)
    ]
    assert edge_times(change, 30.0) == (0.0, 10.0, 11.0, 12.0, 30.0)
    assert [p.name for p in scenario_periods(Scenario(sigma_knots=((10.0, 2.0),)), 11.5)] == ["after_1"]
    with pytest.raises(ValueError, match="leaves no period"):
        scenario_periods(Scenario(sigma_knots=((10.0, 2.0),)), 10.5)


def test_the_statistic_is_the_pooled_mean_square_over_the_clairvoyant_variance_at_the_worst_coordinate(drop):
    """Written out with loops: per period and coordinate i, Σ over seeds and steps of e_i² over S·Σ_k P_ii, rooted;
    the cell is the largest over i (and names that i); the same on fine equal windows (periods on their edges) as on
    windows at the periods."""
    periods, avg, stat = drop
    run = avg.run
    t, step = run.t * run.r_min, run.h * run.r_min  # a window starts at the first step at or after its time
    for p, period in enumerate(periods):
        keep = (t[:-1] >= period.start) & (t[1:] < period.end + step)
        w = run.steps[keep].astype(float)
        num = sum(w[j] * avg.mse[s, np.flatnonzero(keep)[j]] for s in range(SEEDS) for j in range(len(w)))
        den = SEEDS * sum(w[j] * run.ref_var[np.flatnonzero(keep)[j]] for j in range(len(w)))
        per_coordinate = np.sqrt(num / den[None, :])  # (filters, m)
        np.testing.assert_allclose(stat.coordinates[:, p], per_coordinate, rtol=1e-12)
        np.testing.assert_allclose(stat.ratio[:, p], per_coordinate.max(axis=1), rtol=1e-12)
        np.testing.assert_array_equal(stat.coordinate[:, p], per_coordinate.argmax(axis=1))
    _, fine = _average(DROP, windows=80)  # windows of 0.1/r_min: the periods' edges are window edges
    np.testing.assert_allclose(fine.periods().ratio, stat.ratio, rtol=1e-12)


@pytest.mark.parametrize(
    "scenario",
    [
        DROP,
        Scenario(sigma_knots=((3.0, 200.0),)),
        Scenario(sensor_interval=0.1),
        Scenario(noise="outliers", outlier_rate=0.01, outlier_scale=30.0),
    ],
)
def test_the_clairvoyant_filter_reads_one_within_its_sampling_error_in_every_period(scenario):
    """Its squared error averages to P exactly, so each period's ratio² is an unbiased estimate of 1: within 4.5
    standard errors of the seeds' mean (a chance of ~7e-6 per period to miss), and the 95 % interval is that wide."""
    _periods, avg = _average(scenario, edges=edge_times(scenario_periods(scenario, 8.0), 8.0))
    stat = avg.periods()
    y = stat.y[:, :, 0]
    se = y.std(axis=0, ddof=1) / math.sqrt(SEEDS)
    assert np.all(np.abs(y.mean(axis=0) - 1.0) <= 4.5 * se), (y.mean(axis=0), se)
    assert np.all(se < 0.25)  # a check that can fail: the periods hold enough steps and seeds
    assert np.all(stat.low[0] <= stat.ratio[0]) and np.all(stat.ratio[0] <= stat.high[0])


def test_after_the_drop_the_filter_for_sigma0_is_far_off_and_the_learner_recovers(drop):
    periods, _, stat = drop
    kbf, adaptive = stat.filters.index("kbf"), stat.filters.index("kbf_adaptive")
    assert [p.name for p in periods] == ["after_1", "after_2", "settled"]
    assert np.all(stat.low[kbf] > 1.5)  # its gain is for σ = 20, too small after the drop to σ = 2 (2.2 measured)
    assert stat.ratio[adaptive, 2] < stat.ratio[adaptive, 0]  # σ̂ has come down in the settled period


@settings(max_examples=60)
@given(
    arrays(
        np.float64,
        st.tuples(st.integers(1, 12), st.integers(1, 3), st.integers(1, 4)),
        elements=st.floats(0.0, 1e6, allow_nan=False),
    ),
    st.floats(0.5, 0.999),
)
def test_every_interval_contains_its_estimate(y, level):
    ratio, low, high = ratios_from(y, level)
    if y.shape[0] == 1:
        assert np.all(np.isnan(low)) and np.all(np.isnan(high))
    else:
        assert np.all(low <= ratio) and np.all(ratio <= high * (1 + 1e-15))


def test_a_paired_margin_ties_equal_filters_and_tells_a_better_one_through_the_common_noise():
    """Two filters that see the same noise: equal ones tie whatever the seeds' spread; one at half the mean square
    is told apart, although the seeds' spread (a factor 10) dwarfs the difference of their means."""
    rng = np.random.default_rng(3)
    common = 10.0 ** rng.uniform(-1, 0, size=20)
    margin, low = paired_margin(common, common)
    assert margin == pytest.approx(1.0) and low <= 1.0
    margin, low = paired_margin(0.5 * common, common)
    assert margin == pytest.approx(math.sqrt(2.0)) and low == pytest.approx(math.sqrt(2.0))
    noisy = common * rng.uniform(0.5, 1.5, size=20)
    margin, low = paired_margin(common, noisy)
    assert low < margin
