"""Simulation on one Euler grid (:ref:`simulation`): reproducibility, the Run object, long-run RMSE ratios, guard rails.

Monte-Carlo tolerances come from batch means: a long run is cut into B batches much longer than the
filter's settling time 1/r_min, so the batch means of the squared error are nearly independent and
``SE = std(batch means)/√B``; a ratio ``√(mean)/s`` then has ``SE_ratio = ratio·SE/(2·mean)`` (delta method).
"""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest

from isl_core import (
    DivergenceError,
    FilterSpec,
    Model,
    grid,
    isl_filter,
    kalman_bucy,
    optimal_kbf,
    simulate,
    simulate_rmse,
    step_size,
)
from isl_core.filters.base import linearized_matrix
from isl_core.grid import H_RATE, MAX_STORED_STEPS
from isl_core.kernels import advance
from isl_core.kernels.bundles import Batches, Grid, Trajectory
from isl_core.theory import lyapunov

engine = importlib.import_module("isl_core._engine")

EPS = np.finfo(float).eps
FIG3 = Model(0.5, 3.0, 20.0, 3)
Z_BAND = 4.0  # a ±5 % band must be at least this many standard errors wide


def ratio_and_se(res, f: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Whole-run ratio š_i/s_i of filter ``f`` and its batch-means standard error (delta method)."""
    means = res.sq[:, f, :] / res.counts[:, None]
    w = res.counts / res.counts.sum()
    mean = w @ means
    se_mean = means.std(axis=0, ddof=1) / math.sqrt(len(means))
    ratio = np.sqrt(mean) / res.s
    np.testing.assert_allclose(ratio, res.ratios()[f], rtol=64 * EPS)
    return ratio, ratio * se_mean / (2.0 * mean)


# --------------------------------------------------------------------------------------------- the Run object


def test_same_seed_gives_a_bit_identical_run():
    a, b = simulate(FIG3, 3.0, seed=7), simulate(FIG3, 3.0, seed=7)
    for name in ("t", "X", "s"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    for ta, tb in zip(a.tracks, b.tracks, strict=True):
        for name in ("estimate", "rmse", "ratio"):
            np.testing.assert_array_equal(getattr(ta, name), getattr(tb, name))
    assert (a.h, a.T, a.r_min, a.N) == (b.h, b.T, b.r_min, b.N)
    c = simulate(FIG3, 3.0, seed=8)
    assert not np.array_equal(a.X, c.X)


def test_run_layout_and_empirical_rmse():
    run = simulate(FIG3, 3.0, seed=3)
    kb = kalman_bucy(FIG3)
    specs = [optimal_kbf(FIG3, kb), isl_filter(FIG3, 3.0)]
    assert pytest.approx(10.0 / kb.r_min, rel=EPS) == run.T and run.r_min == kb.r_min  # T = 10/r_min (Fig. 3)
    assert run.h <= step_size(FIG3, kb, specs) and run.N * run.h == pytest.approx(run.T, rel=4 * EPS)
    assert math.ceil(run.T / step_size(FIG3, kb, specs) - 1e-9) == run.N
    assert run.t.shape == (run.N + 1,) and run.t[0] == 0.0 and run.t[-1] == pytest.approx(run.T, rel=4 * EPS)
    assert run.X.shape == run.X_hat.shape == run.X_check.shape == (run.N + 1, 3)
    np.testing.assert_array_equal(run.X[0, :2], 0.0)  # the truth starts at 0 except X_m ~ N(0, β²/2α)
    assert run.X[0, 2] != 0.0
    e0 = run.X_hat[0] - run.X[0]  # every filter starts at X(0) − e₀, one common e₀ ~ N(0, Δ)
    assert np.all(e0 != 0.0) and run.start == "stationary"
    np.testing.assert_array_equal(run.X_check[0] - run.X[0], e0)
    for tr in run.tracks:
        np.testing.assert_array_equal(tr.estimate, run.X + tr.error)
    np.testing.assert_array_equal(run.s, kb.s)
    for est, rmse, ratio in [(run.X_hat, run.s_hat, run.ratio_hat), (run.X_check, run.s_check, run.ratio_check)]:
        expected = np.sqrt(np.mean((est[1:] - run.X[1:]) ** 2, axis=0))  # (A.30), k = 1..N
        np.testing.assert_allclose(rmse, expected, rtol=run.N * EPS)
        np.testing.assert_allclose(ratio, rmse / run.s, rtol=EPS)
    assert [tr.name for tr in run.tracks] == ["kbf", "isl"] and run.track("isl") is run.tracks[1]
    with pytest.raises(KeyError, match="no filter named 'x'"):
        run.track("x")
    for arr in (run.t, run.X, run.X_hat, run.X_check, run.s_hat, run.ratio_check):
        assert not arr.flags.writeable


def test_alpha_zero_starts_at_zero():
    run = simulate(Model(0.0, 3.0, 5.0, 3), 3.0, seed=1)
    np.testing.assert_array_equal(run.X[0], 0.0)


def test_start_at_the_truth_as_the_papers_do():
    run = simulate(FIG3, 3.0, seed=1, start="truth")
    assert run.start == "truth"
    for tr in run.tracks:
        np.testing.assert_array_equal(tr.estimate[0], run.X[0])
    with pytest.raises(ValueError, match=r"^start must be one of \['stationary', 'truth'\], got 'zero'"):
        simulate(FIG3, 3.0, start="zero")


@pytest.mark.parametrize("model", [FIG3, Model(0.0, 1.0, 20.0, 6), Model(25.0, 21.2, 2.0, 5)])
def test_start_error_has_the_optimal_covariance(model):
    """e₀ ~ N(0, Δ): each entry of the sample covariance of n draws lies within 5 standard errors of Δ."""
    kb = kalman_bucy(model)
    rng = np.random.default_rng(0)
    n = 20_000
    draws = np.array([engine.initial_error(kb, rng) for _ in range(n)])
    cov = draws.T @ draws / n
    d = np.asarray(kb.delta)
    se = np.sqrt((d**2 + np.outer(np.diag(d), np.diag(d))) / n)  # Var of a Wishart entry / n²
    assert np.all(np.abs(cov - d) <= 5.0 * se)


def test_short_runs_of_the_optimal_filter_are_honest():
    """Started from e₀ ~ N(0, Δ), the optimal filter's error is stationary from t = 0: its mean square over even a
    horizon of 1/r_min is Δ (up to the Euler grid's bias), not the 0.04–0.26 of a start at the truth."""
    ms = np.array([simulate(FIG3, 3.0, horizon=1.0, seed=k).ratio_hat ** 2 for k in range(300)])
    mean, se = ms.mean(axis=0), ms.std(axis=0, ddof=1) / math.sqrt(len(ms))
    assert np.all(np.abs(mean - 1.0) <= 4.0 * se + 2.0 * grid.EULER_BIAS), (mean, se)
    papers = np.array([simulate(FIG3, 3.0, horizon=1.0, seed=k, start="truth").ratio_hat ** 2 for k in range(50)])
    assert np.all(papers.mean(axis=0) < 0.75)


def test_extra_filters_ride_on_the_same_noise():
    kb = kalman_bucy(FIG3)
    copy = FilterSpec("kbf2", "copy of the optimal filter", FIG3.alpha, np.array(kb.K), False)
    plain, more = simulate(FIG3, 3.0, seed=4), simulate(FIG3, 3.0, seed=4, extra=[copy])
    np.testing.assert_array_equal(plain.X, more.X)  # common random numbers: the truth does not change
    np.testing.assert_array_equal(plain.X_check, more.X_check)
    np.testing.assert_array_equal(more.track("kbf2").estimate, more.X_hat)


def test_default_horizon_shorter_than_default_step():
    # T below the stability step: one step of size T (smaller than the rule's h, so still stable)
    kb = kalman_bucy(FIG3)
    h_rule = step_size(FIG3, kb, [optimal_kbf(FIG3, kb), isl_filter(FIG3, 3.0)])
    run = simulate(FIG3, 3.0, T=h_rule / 3)
    assert run.N == 1 and run.h == pytest.approx(h_rule / 3, rel=EPS)


def test_step_size_is_h_rate_over_the_fastest_rate():
    kb = kalman_bucy(FIG3)
    specs = [optimal_kbf(FIG3, kb), isl_filter(FIG3, 3.0)]
    h = step_size(FIG3, kb, specs)
    assert h * max(np.abs(kb.eig).max(), FIG3.alpha) <= H_RATE * (1 + EPS)  # (B.47) with the margin of :ref:`step-size`
    assert step_size(FIG3, kb, specs[:1]) >= h


@pytest.mark.parametrize("m", range(1, 7))
@pytest.mark.parametrize("alpha", [0.0, 1.0])
def test_the_grid_biases_the_optimal_rmse_by_at_most_one_percent(m, alpha):
    """The Euler recursion's own stationary covariance (exact) is within EULER_BIAS of Δ at the rule's step; at
    m = 6 the rate margin alone would leave ≈ 3 % (so the bias bound is what sets h there)."""
    model = Model(alpha, 1.0, 20.0, m)
    kb = kalman_bucy(model)
    h = step_size(model, kb, [optimal_kbf(model, kb)])
    assert grid.euler_bias(model, kb, h) <= grid.EULER_BIAS
    if m == 6 and alpha == 0.0:
        assert grid.euler_bias(model, kb, H_RATE / np.abs(kb.eig).max()) > 2.5 * grid.EULER_BIAS


def test_euler_bias_is_the_simulated_excess_of_the_optimal_filter():
    """Where the grid is coarse on purpose (h·rate = 0.1), the KBF's long-run ratio is 1 + euler_bias, not 1."""
    model = Model(0.0, 1.0, 1.0, 3)
    kb = kalman_bucy(model)
    h = 0.1 / np.abs(kb.eig).max()
    res = simulate_rmse(model, [optimal_kbf(model, kb)], T=4e3 / kb.r_min, h=h, batches=40, seed=3)
    ratio, se = ratio_and_se(res)
    predicted = np.sqrt(
        np.diagonal(
            lyapunov(
                model.A - np.outer(kb.K, model.C[0]),
                model.beta**2 * (model.E @ model.E.T) + np.outer(kb.K, kb.K) * model.sigma**2,
                h,
            )
        )
        / np.diag(kb.delta)
    )
    assert np.max(np.abs(predicted - 1.0)) == pytest.approx(grid.euler_bias(model, kb, h))
    assert np.all(np.abs(ratio - predicted) <= 4.0 * se), (ratio, predicted, se)
    assert np.max(predicted) > 1.0 + 4.0 * np.max(se)  # the bias is real, not sampling noise


def test_step_filters_fix_the_grid_whatever_is_simulated():
    """Filters named in ``step_filters`` count for h: adding or dropping a simulated one then changes nothing else."""
    kb = kalman_bucy(FIG3)
    fast = FilterSpec("fast", "a fast KBF", FIG3.alpha, 8.0 * np.array(kb.K), False)
    alone = simulate(FIG3, 3.0, seed=2, step_filters=[fast])
    both = simulate(FIG3, 3.0, seed=2, extra=[fast], step_filters=[fast])
    plain = simulate(FIG3, 3.0, seed=2)
    assert alone.h == both.h < plain.h
    np.testing.assert_array_equal(alone.X, both.X)
    np.testing.assert_array_equal(alone.X_check, both.X_check)
    np.testing.assert_array_equal(alone.ratio_hat, both.ratio_hat)


def test_a_slower_isl_filter_lengthens_the_run():
    """T = horizon/r with r the slower of the optimal and the ISL filter's settling rates (B.46), if > 10 % slower."""
    kb = kalman_bucy(FIG3)
    fig3 = simulate(FIG3, 3.0, seed=1)
    assert fig3.stretch == 1.0 and pytest.approx(10.0 / kb.r_min, rel=EPS) == fig3.T  # paper A, Fig. 3
    slow_nu = 3.0 / 64
    lam = np.linalg.eigvals(linearized_matrix(FIG3, isl_filter(FIG3, slow_nu)))
    run = simulate(FIG3, slow_nu, seed=1, horizon=10.0)
    assert run.stretch == pytest.approx(kb.r_min / np.min(-lam.real), rel=1e-12) and run.stretch > 3.0
    assert pytest.approx(10.0 * run.stretch / kb.r_min, rel=4 * EPS) == run.T
    assert run.horizon == pytest.approx(10.0 * run.stretch)


def test_errors_keep_their_digits_whatever_the_signal_size():
    """:ref:`error-coordinates`: the errors depend on X only through X_m (and not at all where α = a_f): the same noise
    with a signal shifted by 10¹⁵ gives the same errors, bit for bit — where X − Z computed from states would keep no
    digit."""
    model = Model(0.0, 1.0, 20.0, 6)
    kb = kalman_bucy(model)
    specs = [optimal_kbf(model, kb), isl_filter(model, 1.0)]
    h, n = step_size(model, kb, specs), 20_000
    out = []
    for shift in (0.0, 1e15):
        rng = np.random.default_rng(4)
        x, e0 = engine.draw_start(model, kb, rng, "stationary")
        x[:-1] += shift
        e = np.tile(e0, (2, 1))
        X, E = np.empty((n + 1, 6)), np.empty((2, n + 1, 6))
        advance(
            x,
            e,
            rng,
            n,
            0,
            Grid(h, model.alpha, model.beta),
            model.sigma,
            engine.pack(model, specs),
            Batches(0, n, np.zeros((1, 2, 6)), np.empty((1, 0))),
            Trajectory(True, 0, X, E, np.empty((0, n + 1))),
        )
        out.append((X, E))
    np.testing.assert_array_equal(out[0][1][:, 1:], out[1][1][:, 1:])
    assert np.min(np.abs(out[1][0][1:, 0])) > 1e14


# --------------------------------------------------------------------------------------- simulate_rmse


def test_simulate_rmse_matches_stored_run_across_chunks(monkeypatch):
    monkeypatch.setattr(engine, "CHUNK", 97)  # many kernel calls: batch and burn counters cross chunk edges
    kb = kalman_bucy(FIG3)
    run = simulate(FIG3, 3.0, seed=9, T=200.0)
    burn, batches = 7.3, 6
    res = simulate_rmse(
        FIG3, [optimal_kbf(FIG3, kb), isl_filter(FIG3, 3.0)], T=200.0, seed=9, burn=burn, batches=batches
    )
    assert res.h == run.h and res.names == ("kbf", "isl")
    k0 = int(burn / run.h)
    assert res.counts.sum() == run.N - k0 and np.all(res.counts[:-1] == (run.N - k0) // batches)
    for f, tr in enumerate(run.tracks):
        err2 = (tr.estimate[k0 + 1 :] - run.X[k0 + 1 :]) ** 2
        np.testing.assert_allclose(res.sq[:, f].sum(axis=0), err2.sum(axis=0), rtol=run.N * EPS)
        np.testing.assert_allclose(res.sq[0, f], err2[: int(res.counts[0])].sum(axis=0), rtol=run.N * EPS)
    np.testing.assert_allclose(res.batch_ratios().shape, (batches, 2, 3))


def test_progress_is_reported_and_can_cancel(monkeypatch):
    monkeypatch.setattr(engine, "CHUNK", 1000)
    seen = []
    res = simulate_rmse(FIG3, [isl_filter(FIG3, 3.0)], T=100.0, progress=seen.append)
    assert len(seen) > 2 and seen == sorted(seen) and seen[-1] == 1.0 and np.all(np.isfinite(res.sq))

    class Cancelled(Exception):
        pass

    def cancel(fraction):
        if fraction > 0.3:
            raise Cancelled

    with pytest.raises(Cancelled):
        simulate_rmse(FIG3, [isl_filter(FIG3, 3.0)], T=100.0, progress=cancel)


# ---------------------------------------------------------------------------------- long-run statistics


@pytest.mark.parametrize(
    "model",
    [FIG3, Model(0.5, 3.0, 200.0, 3), Model(25.0, 3.0 * math.sqrt(50.0), 2.0, 3)],
    ids=["fig3-sigma20", "fig3-sigma200", "alpha25-sigma2"],
)
def test_kalman_bucy_empirical_rmse_equals_theory(model):
    """ŝ_i/s_i = 1 ± 5 % on a long run (T = 10⁴/r_min ≥ 1000/r_min), and ±5 % is a ≥ 4-SE band."""
    kb = kalman_bucy(model)
    res = simulate_rmse(model, [optimal_kbf(model, kb)], T=1e4 / kb.r_min, burn=10.0 / kb.r_min, batches=50, seed=2024)
    ratio, se = ratio_and_se(res)
    assert np.all(Z_BAND * se <= 0.05), f"run too short for a ±5 % test: SE = {se}"
    assert np.all(np.abs(ratio - 1.0) <= 0.05), f"ratio {ratio} ± {se}"


def test_isl_m1_alpha0_ratio_is_b52():
    """m = 1, α = 0, ν = β: š/s → (π/2)^{1/4} as h → 0 (B.52).

    The Euler scheme's bias is O(h·rate) (about +1 % at the rule's step); it is measured and removed by
    Richardson extrapolation 2·r(h/2) − r(h) from runs at h and h/2, whose batch-means errors combine to
    SE = √(4·SE(h/2)² + SE(h)²).
    """
    model = Model(0.0, 1.0, 1.0, 1)
    kb = kalman_bucy(model)
    specs = [isl_filter(model, model.beta)]
    h0 = step_size(model, kb, specs)
    target = (math.pi / 2.0) ** 0.25
    r, se = {}, {}
    for h in (h0, h0 / 2):
        res = simulate_rmse(model, specs, T=2e5 / kb.r_min, h=h, burn=10.0 / kb.r_min, batches=100, seed=52)
        r[h], se[h] = (v[0] for v in ratio_and_se(res))
    limit = 2.0 * r[h0 / 2] - r[h0]
    se_limit = math.sqrt(4.0 * se[h0 / 2] ** 2 + se[h0] ** 2)
    bias = r[h0] - r[h0 / 2]  # ≈ the Euler bias at h/2 (half of that at h)
    assert Z_BAND * se_limit <= 0.02, f"run too short: SE = {se_limit}"
    assert abs(limit - target) <= Z_BAND * se_limit, f"{limit} ± {se_limit} (Euler bias at h/2 ≈ {bias:+.4f})"
    assert abs(bias) <= 0.05 * target, "the Euler bias should be O(h·rate) = O(H_RATE)"


# ------------------------------------------------------------------------------------------ guard rails


def test_divergence_is_reported_with_its_time():
    with pytest.raises(DivergenceError, match=r"diverged at t = [0-9.e+]+ \(step"):
        simulate(FIG3, 3.0, h=10.0, T=1e4)
    kb = kalman_bucy(FIG3)
    with pytest.raises(DivergenceError, match=r"diverged at t = .*h·alpha = 5 >= 2 makes the Euler scheme unstable"):
        simulate_rmse(FIG3, [optimal_kbf(FIG3, kb)], T=1e4, h=10.0)


def test_a_filter_that_blows_up_is_named():
    wild = FilterSpec("wild", "unstable filter", 0.0, np.array([-50.0, 0.0, 0.0]), False)  # Λ_11 = +50
    with pytest.raises(DivergenceError, match=r"filter unstable filter diverged at t = "):
        simulate(FIG3, 3.0, T=100.0, extra=[wild])


@pytest.mark.parametrize("T, h", [(1e9, None), (1e6, 1e-6), (1e300, 1e-300), (1.7e308, 1e-10)])
def test_too_many_steps_is_a_clear_error(T, h):
    with pytest.raises(ValueError, match=r"^T/h = .* needs .* steps, over the limit of 4,000,000"):
        simulate(FIG3, 3.0, T=T, h=h)
    assert MAX_STORED_STEPS == 4_000_000


BAD = [math.nan, math.inf, -math.inf, None, "1", True, -1.0, 0.0, 1 + 1j]


@pytest.mark.parametrize(
    ("name", "value"), [("nu", v) for v in BAD] + [(n, v) for n in ("T", "h") for v in BAD if v is not None]
)  # None: default
def test_bad_simulate_inputs_name_the_parameter(name, value):
    kwargs = {"nu": 3.0, "T": 50.0, "h": None}
    kwargs[name] = value
    with pytest.raises(ValueError, match=rf"^{name} must be a finite number > 0"):
        simulate(FIG3, kwargs.pop("nu"), **kwargs)


def test_h_larger_than_T():
    with pytest.raises(ValueError, match=r"^h must be a finite number > 0 and <= T = 1, got 2"):
        simulate(FIG3, 3.0, T=1.0, h=2.0)


@pytest.mark.parametrize("seed", [-1, 1.5, math.nan, None, "0", True, [1]])
def test_bad_seed(seed):
    with pytest.raises(ValueError, match=r"^seed must be an integer >= 0"):
        simulate(FIG3, 3.0, seed=seed)
    with pytest.raises(ValueError, match=r"^seed must be an integer >= 0"):
        simulate_rmse(FIG3, [isl_filter(FIG3, 3.0)], T=10.0, seed=seed)


@pytest.mark.parametrize("model", [None, "model", (0.5, 3.0, 20.0, 3)])
def test_bad_model(model):
    with pytest.raises(ValueError, match=r"^model must be an isl_core.Model"):
        simulate(model, 3.0)
    with pytest.raises(ValueError, match=r"^model must be an isl_core.Model"):
        simulate_rmse(model, [isl_filter(FIG3, 3.0)], T=10.0)


def test_bad_filters_and_extra():
    other = isl_filter(Model(0.5, 3.0, 20.0, 2), 3.0)
    for bad in ([], [other], [None], "isl", None, isl_filter(FIG3, 3.0)):
        with pytest.raises(ValueError, match=r"^filters must be a non-empty sequence of FilterSpec of size m = 3"):
            simulate_rmse(FIG3, bad, T=10.0)
    for bad in ([other], [1.0], "isl", None, 3):
        with pytest.raises(ValueError, match=r"^extra must be a sequence of FilterSpec of size m = 3"):
            simulate(FIG3, 3.0, extra=bad)


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        ({"batches": 0}, r"^batches must be an integer >= 1"),
        ({"batches": 2.5}, r"^batches must be an integer >= 1"),
        ({"batches": 10**9}, r"^batches must be an integer >= 1 and <= 10000"),
        ({"batches": 9000, "T": 1.0}, r"^batches must be <= the number of steps"),
        ({"burn": -1.0}, r"^burn must be a finite number >= 0 and <= 10"),
        ({"burn": math.nan}, r"^burn must be a finite number >= 0"),
        ({"burn": 1e308}, r"^burn must be a finite number >= 0 and <= 10"),
        ({"progress": 3}, r"^progress must be a callable or None"),
        ({"h": -1.0}, r"^h must be a finite number > 0"),
        ({"T": None}, r"^T must be a finite number > 0; got nothing \(an empty box or a missing value\)"),
    ],
)
def test_bad_simulate_rmse_inputs(kwargs, pattern):
    kwargs = {"T": 10.0, **kwargs}
    with pytest.raises(ValueError, match=pattern):
        simulate_rmse(FIG3, [isl_filter(FIG3, 3.0)], **kwargs)


def test_every_kth_step_is_the_same_run_thinned():
    full = simulate(FIG3, 3.0, horizon=50.0, seed=6)
    thin = simulate(FIG3, 3.0, horizon=50.0, seed=6, every=7)
    assert thin.N == full.N and thin.every == 7 and len(thin.t) == -(-(full.N + 1) // 7)
    np.testing.assert_array_equal(thin.t, full.t[::7])
    np.testing.assert_array_equal(thin.X, full.X[::7])
    for a, b in zip(thin.tracks, full.tracks, strict=True):
        np.testing.assert_array_equal(a.error, b.error[::7])
        np.testing.assert_allclose(a.rmse, b.rmse, rtol=1e-12)  # over every step, not the kept ones
