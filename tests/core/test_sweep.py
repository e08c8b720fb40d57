"""Sweeps (:ref:`empirical-rmse`): optimal filter at its own RMSE, theory alongside, and reproducibility across
executors."""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import itertools
import math

import numpy as np
import pytest
from scipy.linalg import solve_discrete_lyapunov

from isl_core import (
    Execution,
    FilterSpec,
    Model,
    Sampling,
    isl_filter,
    kalman_bucy,
    optimal_kbf,
    predicted_ratios_grid,
    simulate_rmse,
)
from isl_core.grid import H_RATE
from isl_core.jobs import Task, run_task
from isl_core.sweep import group_seed, sweep

ALPHAS = (0.04, 1.0, 25.0)
SIGMAS = (2.0, 200.0)
NOB = (2.0**-6, 2.0**-2, 1.0)
SAMPLING = Sampling(seeds=(3, 4), horizon=40.0, batches=8)
SMALL = dict(m=3, w=3.0, sampling=SAMPLING)


@pytest.fixture(scope="module")
def local():
    return sweep(ALPHAS, SIGMAS, NOB, **SMALL)


def _arrays(res):
    fields = {f.name: getattr(res, f.name) for f in dataclasses.fields(res)}
    return {name: v for name, v in fields.items() if isinstance(v, np.ndarray)}


def _assert_identical(a, b):
    for name, arr in _arrays(a).items():
        assert np.array_equal(arr, getattr(b, name), equal_nan=True), name


def _euler_kbf_ratio(model: Model, h: float) -> np.ndarray:
    """Exact stationary RMSE ratio of the Euler-discretized Kalman–Bucy filter on the Euler truth (B.30, B.33).

    e_{k+1} = (I + h(A − KC)) e_k + √h(σKε_k − βEv_k): a discrete Lyapunov equation; → 1 as h → 0.
    """
    kb = kalman_bucy(model)
    F = np.eye(model.m) + h * (model.A - np.outer(kb.K, model.C[0]))
    Q = h * (model.beta**2 * (model.E @ model.E.T) + model.sigma**2 * np.outer(kb.K, kb.K))
    return np.sqrt(np.diag(solve_discrete_lyapunov(F, Q))) / kb.s


def test_shapes_and_theory(local):
    na, ns, nn = len(ALPHAS), len(SIGMAS), len(NOB)
    assert local.ratio.shape == local.theory.shape == (na, ns, nn, 3)
    assert local.kbf_ratio.shape == (na, ns, 3)
    assert np.all(local.ratio_low <= local.ratio) and np.all(local.ratio <= local.ratio_high)
    assert np.all(local.steps > 0) and np.all(local.h > 0)
    for a, alpha in enumerate(ALPHAS):
        for b, sigma in enumerate(SIGMAS):
            model = Model.from_w(alpha, 3.0, sigma, 3)
            assert np.array_equal(local.theory[a, b], predicted_ratios_grid(model, model.beta * np.array(NOB)))
            assert np.allclose(local.s[a, b], kalman_bucy(model).s)
    assert len(local.records()) == na * ns * nn * 3


def test_kbf_ratio_within_its_interval():
    """The optimal filter's measured ratio covers its expected value: 1 up to the Euler scheme's O(h) shift.

    Family-wise: 18 intervals at individual level 1 − 0.01/18 (Bonferroni) miss any with probability ≤ 1 %,
    so with the fixed seeds the test cannot flip by chance beyond that bound; the Euler shift (exact, by the
    discrete Lyapunov equation) is itself checked to be under H_RATE = h × fastest rate (2 %).
    """
    k = len(ALPHAS) * len(SIGMAS) * 3
    sampling = dataclasses.replace(SAMPLING, horizon=300.0, level=1.0 - 0.01 / k)
    res = sweep(ALPHAS, SIGMAS, [1.0], m=3, w=3.0, sampling=sampling)
    for a, alpha in enumerate(ALPHAS):
        for b, sigma in enumerate(SIGMAS):
            expected = _euler_kbf_ratio(Model.from_w(alpha, 3.0, sigma, 3), res.h[a, b])
            assert np.all(np.abs(expected - 1.0) < H_RATE)  # O(h·rate), h·rate ≤ H_RATE
            assert np.all(res.kbf_low[a, b] <= expected), (alpha, sigma, res.kbf_low[a, b], expected)
            assert np.all(expected <= res.kbf_high[a, b]), (alpha, sigma, res.kbf_high[a, b], expected)


def test_independent_of_workers_and_chunking(local):
    _assert_identical(local, sweep(ALPHAS, SIGMAS, NOB, **SMALL, execution=Execution(workers=1)))
    with cf.ThreadPoolExecutor(max_workers=2) as pool:
        _assert_identical(local, sweep(ALPHAS, SIGMAS, NOB, **SMALL, execution=Execution(executor=pool, chunk=4)))


def test_group_seed_does_not_depend_on_the_grid(local):
    """A sub-grid reproduces the matching slice: each group's seed comes from its own (seed, α, σ, w, m)."""
    sub = sweep([ALPHAS[1]], [SIGMAS[1]], NOB, **SMALL)
    assert np.array_equal(sub.ratio[0, 0], local.ratio[1, 1])
    assert np.array_equal(sub.kbf_ratio[0, 0], local.kbf_ratio[1, 1])
    assert group_seed(3, 1.0, 2.0, 3.0, 3) != group_seed(4, 1.0, 2.0, 3.0, 3) != group_seed(3, 1.0, 20.0, 3.0, 3)


def test_dask_local_cluster_gives_identical_results(local):
    import distributed  # the dask extra: installed with the tests (ISL_EXTRAS=test,dask)

    with (
        distributed.LocalCluster(n_workers=2, processes=False, threads_per_worker=1, dashboard_address=None) as cl,
        distributed.Client(cl) as client,
    ):
        remote = sweep(ALPHAS, SIGMAS, NOB, **SMALL, execution=Execution(executor=client, chunk=2))
    _assert_identical(local, remote)


def test_progress_is_monotone_and_cancels():
    seen = []
    sweep([1.0], [20.0], [0.5, 1.0], **SMALL, execution=Execution(progress=seen.append))
    assert seen and seen[-1] == pytest.approx(1.0) and all(b >= a for a, b in itertools.pairwise(seen))

    class Stop(Exception):
        pass

    calls = []

    def stop(fraction):
        calls.append(fraction)
        raise Stop

    # 4 groups of ~10⁷ steps (~80 kernel chunks each): the first report cancels all of them at once
    with pytest.raises(Stop):
        sampling = Sampling(seeds=(0, 1, 2, 3), horizon=400.0)
        sweep([25.0], [200.0], [1.0], sampling=sampling, execution=Execution(workers=2, progress=stop))
    assert len(calls) == 1


def test_diverged_filter_is_nan_and_others_unchanged():
    """A filter that blows up is reported as nan; the others keep the numbers of their own runs (same noise)."""
    model = Model.from_w(1.0, 3.0, 20.0, 3)
    kb = kalman_bucy(model)
    wild = FilterSpec("wild", "linear gain ×50", model.alpha, 50.0 * np.array(kb.K), False)
    filters = (optimal_kbf(model, kb), wild, isl_filter(model, model.beta))
    h, n = 0.15, 4000
    res = run_task(Task((0, 0, 0), model, filters, n * h, h, 10 * h, 4, 9, n))
    sq, counts = res.sq, res.counts
    assert np.all(np.isnan(sq[:, 1])) and np.all(np.isfinite(sq[:, [0, 2]]))
    alone = simulate_rmse(model, [filters[2]], T=n * h, h=h, burn=10 * h, batches=4, seed=9)
    assert np.array_equal(sq[:, 2], alone.sq[:, 0]) and np.array_equal(counts, alone.counts)


@pytest.mark.parametrize(
    "kw, name",
    [
        (dict(alphas=[]), "alphas"),
        (dict(alphas=[0.0]), "alphas"),
        (dict(sigmas=[math.nan]), "sigmas"),
        (dict(nu_over_beta=[-1.0]), "nu_over_beta"),
        (dict(m=7), "m"),
        (dict(w=0.0), "w"),
        (dict(horizon=math.inf), "horizon"),
        (dict(seeds=[-1]), "seeds"),
        (dict(seeds=[]), "seeds"),
        (dict(batches=0), "batches"),
        (dict(level=1.0), "level"),
        (dict(chunk=0), "chunk"),
        (dict(horizon=1e9), "horizon"),
        (dict(workers=0), "workers"),
        (dict(progress=3), "progress"),
    ],
)
def test_bad_arguments_name_the_parameter(kw, name):
    """Each argument, of the sweep or of its requests, refused by name (a request when it is made)."""
    args = dict(alphas=[1.0], sigmas=[20.0], nu_over_beta=[1.0], horizon=10.0) | kw
    sampling = {k: args.pop(k) for k in ("seeds", "horizon", "batches", "level") if k in args}
    execution = {k: args.pop(k) for k in ("workers", "chunk", "progress") if k in args}
    with pytest.raises(ValueError, match=name):
        requests = dict(sampling=Sampling(**sampling), execution=Execution(**execution))
        sweep(args.pop("alphas"), args.pop("sigmas"), args.pop("nu_over_beta"), **args, **requests)


def test_a_failing_task_stops_the_others_and_its_own_error_propagates():
    """The job runner (isl_core.jobs) shared by the sweep and the worst case: a progress callback that raises
    cancels every task and its exception — not a cancellation it caused — reaches the caller."""
    from isl_core.jobs import Task, run

    model = Model(1.0, 3.0, 20.0, 2)
    filters = (optimal_kbf(model, kalman_bucy(model)),)
    tasks = [Task(k, model, filters, 2000 * 1e-3, 1e-3, 0.0, 2, k, 2000) for k in range(4)]
    calls = []

    def progress(fraction):
        calls.append(fraction)
        raise KeyboardInterrupt("the user pressed Cancel")

    with pytest.raises(KeyboardInterrupt, match="pressed Cancel"):
        run(tasks, Execution(workers=2, progress=progress))
    assert len(calls) == 1  # no report reaches the callback after it raised
    results = run(tasks, Execution(workers=2))
    assert sorted(r.key for r in results) == [0, 1, 2, 3] and all(r.sq.shape == (2, 1, 2) for r in results)
