"""Worst case over an unknown σ: the table's internal consistency, its tunings, and its independence of executors.

The Fig. 2 table (α ∈ {0.04, 0.2, 1, 5, 25}, σ ∈ [2, 200], m = 3, w = 3) is simulated once with a short horizon
(module fixture). Its intervals are at a Bonferroni level, 1 − 0.05/(number of intervals checked), so that
"every interval covers" is a 95 % statement about the whole table.
"""

from __future__ import annotations

import concurrent.futures as cf
import math

import numpy as np
import pytest
from _requests import requests

from isl_core import Model, kalman_bucy, optimal_kbf, recommend_nu
from isl_core.paper import A31_NU_OVER_BETA
from isl_core.theory import predicted_covariance
from isl_core.worstcase import WORST_CASE_FILTERS as FILTERS
from isl_core.worstcase import WORST_CASE_LABELS as LABELS
from isl_core.worstcase import worst_case

ALPHAS = (0.04, 0.2, 1.0, 5.0, 25.0)
N_SIGMA = 3
M = 3
LEVEL = 1.0 - 0.05 / (len(ALPHAS) * N_SIGMA * M)


@pytest.fixture(scope="module")
def table():
    sampling = requests(horizon=60.0, seeds=(3,), batches=6, level=LEVEL)
    return worst_case(ALPHAS, sigma_range=(2.0, 200.0), n_sigma=N_SIGMA, m=M, w=3.0, **sampling)


def test_layout(table):
    na, ns, nf = len(ALPHAS), N_SIGMA, len(FILTERS)
    assert table.names == FILTERS and len(table.labels) == nf
    np.testing.assert_allclose(table.sigmas, [2.0, 20.0, 200.0], rtol=1e-12)
    assert table.sigmas[0] == 2.0 and table.sigmas[-1] == 200.0
    for arr in (table.ratio, table.low, table.high, table.theory):
        assert arr.shape == (na, ns, nf, M) and not arr.flags.writeable
    assert table.worst.shape == table.theory_worst.shape == table.nu.shape == (na, nf)
    assert len(table.records()) == na * nf
    assert np.all(np.isfinite(table.ratio))  # nothing diverged


def test_each_worst_case_bounds_every_per_sigma_value(table):
    worst, ratio = table.worst, table.ratio
    assert np.all(worst[:, None, :, None] >= ratio)
    assert np.all(table.worst_high[:, None, :, None] >= table.high)
    assert np.all(table.worst_low[:, None, :, None] >= table.low)
    assert np.all((table.worst_low <= worst) & (worst <= table.worst_high))
    for a in range(len(ALPHAS)):
        for f in range(len(FILTERS)):  # the worst case is attained where the table says
            b = int(np.flatnonzero(table.sigmas == table.worst_sigma[a, f])[0])
            assert ratio[a, b, f, table.worst_i[a, f] - 1] == worst[a, f]
    finite = ~np.isnan(table.theory)
    assert np.all((table.theory_worst[:, None, :, None] >= table.theory)[finite])


def test_kbf_oracle_is_one(table):
    """Theory: exactly 1. Simulation: every interval covers the oracle's exact Euler-grid value (1 + O(h·rate))."""
    f = FILTERS.index("kbf")
    np.testing.assert_allclose(table.theory[:, :, f], 1.0, rtol=1e-9)
    for a, alpha in enumerate(ALPHAS):
        for b, sigma in enumerate(table.sigmas):
            model = Model.from_w(alpha, 3.0, sigma, M)
            kb = kalman_bucy(model)
            grid = np.sqrt(np.diag(predicted_covariance(model, optimal_kbf(model, kb), h=table.h[a, b]))) / kb.s
            assert np.all(np.abs(grid - 1.0) <= 0.02)
            assert np.all((table.low[a, b, f] <= grid) & (grid <= table.high[a, b, f])), (alpha, sigma)


def test_adaptive_tracks_the_oracle_and_fixed_gains_pay_for_not_knowing_sigma(table):
    """On the same noise the adaptive filter sits within 1 % of the oracle at every σ; no theory for it."""
    k, ad = FILTERS.index("kbf"), FILTERS.index("kbf_adaptive")
    assert np.all(np.abs(table.ratio[:, :, ad] - table.ratio[:, :, k]) <= 0.01)
    assert np.all(np.isnan(table.theory[:, :, ad])) and np.all(np.isnan(table.theory_worst[:, ad]))
    mid, top = FILTERS.index("kbf_mismatched"), FILTERS.index("kbf_minimax")
    assert np.all(table.theory_worst[:, mid] >= table.best_fixed_worst * (1 - 1e-9))  # no fixed gain beats that
    # σ̄ = σ_max: gain far too small at σ_min. Its errors decorrelate ~(σ_max/σ_min)^{1/m} times slower than
    # the oracle's, so short batches give it wide intervals: compare the estimates themselves.
    assert np.all(table.theory_worst[:, top] > 2.0 * table.theory_worst[:, mid])
    assert np.all(table.worst[:, top] > table.worst[:, mid])


def test_tunings(table):
    sig = tuple(table.sigmas)
    isl, aware = FILTERS.index("isl"), FILTERS.index("isl_model")
    for a, alpha in enumerate(ALPHAS):
        assert table.nu[a, isl] == recommend_nu(alpha, sigmas=sig, verify=False).nu
        assert table.nu[a, aware] == recommend_nu(alpha, sigmas=sig, verify=False, model_aware=True).nu
    np.testing.assert_allclose(table.sigma_design[:, FILTERS.index("kbf_mismatched")], 20.0, rtol=1e-12)
    np.testing.assert_array_equal(table.sigma_design[:, FILTERS.index("kbf_minimax")], 200.0)
    assert np.all(np.isnan(table.nu[:, [FILTERS.index(n) for n in FILTERS if not n.startswith("isl")]]))


def test_paper_tuning_beside_the_minimax_tuning(table):
    """Two ISL columns, each saying where its ν comes from: the project's minimax ν and paper A's table (A.31)."""
    a31, isl = FILTERS.index("isl_a31"), FILTERS.index("isl")
    assert table.labels[a31] == LABELS["isl_a31"] == "ISL, ν from table A.31"
    assert table.labels[isl] == "ISL, minimax ν"
    for a, alpha in enumerate(ALPHAS):
        beta = 3.0 * math.sqrt(2.0 * alpha)
        assert table.nu[a, a31] == pytest.approx(A31_NU_OVER_BETA[alpha] * beta, rel=1e-12)
    assert np.all(np.isfinite(table.worst[:, a31]))
    # where the table has no α, the paper's column is not simulated (nan), the others are
    other = worst_case(
        [0.5],
        sigma_range=(2.0, 200.0),
        n_sigma=2,
        **requests(True, horizon=20.0, seeds=(1,), batches=2, filters=("kbf", "isl", "isl_a31")),
    )
    assert np.isnan(other.worst[0, 2]) and np.isnan(other.nu[0, 2]) and np.all(np.isfinite(other.worst[0, :2]))


def test_same_result_on_another_executor_and_chunking():
    kw = {
        "sigma_range": (5.0, 50.0),
        "n_sigma": 2,
        "horizon": 20.0,
        "seeds": (1, 2),
        "batches": 2,
        "filters": ("kbf_adaptive", "isl"),
    }
    local = worst_case([1.0], **requests(True, workers=1, **kw))
    with cf.ThreadPoolExecutor(2) as pool:
        other = worst_case([1.0], **requests(True, executor=pool, chunk=3, **kw))
    assert local.names == ("kbf_adaptive", "isl")
    for name in ("ratio", "low", "high", "theory", "nu"):
        np.testing.assert_array_equal(getattr(local, name), getattr(other, name))


def test_progress_reaches_one_and_can_cancel():
    seen = []
    worst_case(
        [1.0],
        sigma_range=(5.0, 50.0),
        n_sigma=2,
        **requests(True, horizon=10.0, seeds=(0,), batches=2, filters=("kbf",), progress=seen.append),
    )
    assert seen and seen[-1] == pytest.approx(1.0)

    class Stop(Exception):
        pass

    def stop(fraction):
        raise Stop

    with pytest.raises(Stop):
        worst_case(
            [1.0], sigma_range=(5.0, 50.0), n_sigma=2, **requests(horizon=10.0, seeds=(0,), batches=2, progress=stop)
        )


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        ({"alphas": []}, r"^alphas must be a non-empty sequence"),
        ({"alphas": [0.0]}, r"^alphas must be a finite number > 0"),
        ({"sigma_range": (2.0, 2.0)}, r"^sigma_range must have sigma_max > sigma_min"),
        ({"sigma_range": (5.0, 2.0)}, r"^sigma_range\[1\] must be a finite number >= 5"),
        ({"n_sigma": 1}, r"^n_sigma must be an integer >= 2"),
        ({"filters": ("kbf", "x")}, r"^filters must be a non-empty sequence of distinct names"),
        ({"sigma_design": -1.0}, r"^sigma_design must be a finite number > 0"),
        ({"horizon": math.inf}, r"^horizon must be a finite number > 0"),
        ({"seeds": ()}, r"^seeds must be a non-empty sequence"),
        ({"memory": 0.0}, r"^memory \(W, in readings\) must be a finite number >= 1"),
        ({"progress": 3}, r"^progress must be a callable or None"),
        ({"m": 7}, r"^m must be an integer >= 1 and <= 6"),
    ],
)
def test_bad_arguments_name_the_parameter(kwargs, pattern):
    kwargs = {"alphas": [1.0], "horizon": 5.0, **kwargs}
    with pytest.raises(ValueError, match=pattern):
        worst_case(kwargs.pop("alphas"), **requests(True, **kwargs))


def test_model_aware_option_of_sweep_and_recommend():
    """The model-aware ISL filter in the sweep (theory with damp = α) and in the verified recommendation."""
    from isl_core import sweep
    from isl_core.theory import predicted_ratios_grid

    short = requests(horizon=20.0, seeds=(0,), batches=2)
    res = sweep([1.0], [20.0], [0.125, 0.5], model_aware=True, **short)
    model = Model.from_w(1.0, 3.0, 20.0, 3)
    assert res.model_aware
    np.testing.assert_array_equal(
        res.theory[0, 0], predicted_ratios_grid(model, model.beta * np.array([0.125, 0.5]), damp=1.0)
    )
    plain = sweep([1.0], [20.0], [0.125, 0.5], **short)
    assert not plain.model_aware and not np.array_equal(plain.theory, res.theory)
    assert np.all(np.isfinite(res.ratio)) and np.all(np.isfinite(res.kbf_ratio))
    rec = recommend_nu(1.0, sigmas=(2.0, 200.0), model_aware=True, **short)
    assert rec.model_aware and rec.simulated_low <= rec.simulated_worst <= rec.simulated_high
    assert rec.theory_worst < recommend_nu(1.0, sigmas=(2.0, 200.0), verify=False).theory_worst
    with pytest.raises(ValueError, match=r"^model_aware must be True or False"):
        recommend_nu(1.0, verify=False, model_aware=1)
