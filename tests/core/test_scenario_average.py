"""Scenario runs over seeds in time (isl_core.scenario.average) and the who-wins map's ties."""

from __future__ import annotations

import numpy as np
import pytest

from isl_core import Model, Scenario, average_scenario, simulate_scenario, who_wins_map
from isl_core.filters.adaptive import adaptive_kbf
from isl_core.scenario.average import margin_low, resampled, worst_ratio

MODEL = Model.from_w(1.0, 3.0, 20.0, 3)
DROP = Scenario(sigma_knots=((6.0, 2.0),))


@pytest.fixture(scope="module")
def average():
    extra = [adaptive_kbf(MODEL, sigma_range=(2.0, 200.0), sigma_init=20.0)]
    return average_scenario(MODEL, 1.0, DROP, seeds=range(3, 9), horizon=12.0, windows=120, extra=extra)


def test_each_seed_is_its_own_run(average):
    again = simulate_scenario(
        MODEL,
        1.0,
        DROP,
        horizon=12.0,
        windows=120,
        seed=5,
        extra=[adaptive_kbf(MODEL, sigma_range=(2.0, 200.0), sigma_init=20.0)],
    )
    assert average.seeds == (3, 4, 5, 6, 7, 8)
    np.testing.assert_array_equal(average.mse[2], again.mse)
    np.testing.assert_array_equal(average.sigma_hat[2], again.sigma_hat)
    assert average.learning == ("kbf_adaptive",)


def test_the_rolling_ratio_is_the_windows_pooled_by_steps(average):
    """Written out directly: a window of k short windows pools their squared errors and variances by steps."""
    roll = average.rolling(1.0)
    run = average.run
    k = 10  # 12/r_min over 120 short windows: 1/r_min is 10 of them
    w = run.steps.astype(float)
    j = 37
    sl = slice(j, j + k)
    mse = np.einsum("w,swfm->sfm", w[sl], average.mse[:, sl]) / w[sl].sum()
    ref = np.einsum("w,wm->m", w[sl], run.ref_var[sl]) / w[sl].sum()
    per = np.sqrt(mse.mean(axis=0) / ref)  # (f, m)
    np.testing.assert_allclose(roll.ratio[j], per.max(axis=1), rtol=1e-12)
    np.testing.assert_array_equal(roll.coordinate[j], per.argmax(axis=1))
    assert roll.t[j] == pytest.approx((run.t[j] + run.t[j + k]) / 2 * run.r_min)
    assert len(roll.t) == len(run.steps) - k + 1
    # the interval: mean ± 1.96 s/√S of the picked coordinate's window mean square, under the square root
    f, i = 2, per[2].argmax()
    half = 1.959963984540054 * mse[:, f, i].std(ddof=1) / np.sqrt(len(average.seeds))
    assert roll.low[j, f] == pytest.approx(np.sqrt((mse[:, f, i].mean() - half) / ref[i]), rel=1e-12)
    assert roll.high[j, f] == pytest.approx(np.sqrt((mse[:, f, i].mean() + half) / ref[i]), rel=1e-12)
    assert roll.width == pytest.approx(1.0, rel=0.02)
    assert run.t[-1] * run.r_min == pytest.approx(12.0)  # the horizon asked for, not lengthened


def test_the_picture_shows_the_step(average):
    roll = average.rolling(1.0)
    before, after = roll.t < 5.0, roll.t > 11.0
    assert np.all(roll.sigma[before] == 20.0) and np.allclose(roll.sigma[after], 2.0)
    # the filter designed for σ(0) = 20 is far off after σ dropped tenfold; the clairvoyant one is not
    assert roll.ratio[after, 1].mean() > 2.0 * roll.ratio[after, 0].mean()
    # the adaptive filter's σ̂ comes down from 20 after the step, towards 2 (slowly: about halfway in 6/r_min)
    sh = roll.sigma_hat[:, 0]
    assert sh[after][-1] < 0.6 * sh[before].mean() and sh[after][-1] < sh[after][0]


def test_a_single_run_has_no_interval_and_no_worst_case():
    one = average_scenario(MODEL, 1.0, Scenario(), seeds=[0], horizon=6.0, windows=30)
    roll = one.rolling(1.0)
    assert np.all(np.isnan(roll.low)) and np.all(np.isfinite(roll.ratio))
    with pytest.raises(ValueError, match="2 seeds"):
        one.worst()


def test_the_worst_case_is_the_table_statistic_over_the_rolling_windows(average):
    point, low, high = average.worst(width=1.0, burn=2.0)
    roll = average.rolling(1.0)
    keep = roll.t - roll.width / 2 >= 2.0 - 1e-9
    assert point == pytest.approx(roll.ratio[keep].max(axis=0), rel=1e-12)
    assert np.all(low < high)
    # the bootstrap is the table's: the same numbers for the same inputs and resampling seed
    mse = np.random.default_rng(1).random((5, 4, 2, 3))
    ref = np.full((4, 3), 0.5)
    a = worst_ratio(mse, ref, 0.95, np.random.default_rng(7))
    b = worst_ratio(mse, ref, 0.95, np.random.default_rng(7))
    np.testing.assert_array_equal(a, b)
    assert a[0] == pytest.approx(np.sqrt(mse.mean(axis=0) / ref[:, None, :]).max(axis=(0, 2)))


@pytest.mark.parametrize("kwargs, named", [({"seeds": []}, "seeds"), ({"seeds": [-1]}, "seed")])
def test_bad_seeds_are_named(kwargs, named):
    with pytest.raises(ValueError, match=named):
        average_scenario(MODEL, 1.0, **kwargs)


def test_bad_windows_are_named(average):
    with pytest.raises(ValueError, match="width"):
        average.rolling(0.0)
    with pytest.raises(ValueError, match="burn"):
        average.worst(burn=50.0)


def test_the_map_calls_a_tie_only_where_the_seeds_cannot_tell():
    res = who_wins_map("sensor", 1.0, values=[0.0, 0.5], n_seeds=6, untuned=True)
    assert res.margin_low.shape == res.margin.shape == (1, 2)
    assert np.all(res.margin_low <= res.margin + 1e-12)
    np.testing.assert_array_equal(res.tie, res.margin_low <= 1.0)


def test_the_paired_margin_is_a_tie_for_equal_filters_and_not_for_a_clearly_better_one():
    """Filters 1 and 2 see the same noise (seeds): one equal to the other is a tie whatever the seeds' spread; one
    at half the error is told apart, although the seeds' spread (a factor 10) dwarfs the difference of their means."""
    rng = np.random.default_rng(3)
    common = 10.0 ** rng.uniform(-1, 0, size=(20, 1))  # per seed: the noise both filters share

    def mean(a: np.ndarray) -> np.ndarray:  # (filters,): filter 0 (a reference, left out), 1 and 2
        return a.mean(axis=0)

    same = np.hstack([common, common, common])
    point, boot = resampled(mean, same, np.random.default_rng(1))
    assert margin_low(point, boot) <= 1.0
    half = np.hstack([common, common, 0.5 * common])
    point, boot = resampled(mean, half, np.random.default_rng(1))
    assert margin_low(point, boot) == pytest.approx(2.0)
    noisy = np.hstack([common, common * rng.uniform(0.5, 1.5, size=(20, 1)), common])
    point, boot = resampled(mean, noisy, np.random.default_rng(1))
    assert margin_low(point, boot) < point[1:].max() / point[1:].min()
