"""The compiled Euler loop (isl_core.kernels.euler) against the plain-numpy reference (same noise), batching,
chunking."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from isl_core import FilterSpec, Model, isl_filter, isl_gains, kalman_bucy, optimal_kbf, simulate
from isl_core._engine import draw_start, pack
from isl_core.filters.adaptive import adaptive_kbf
from isl_core.kernels.bundles import Batches, Grid, Trajectory
from isl_core.kernels.common import FLUSH
from isl_core.kernels.euler import advance
from isl_core.reference import reference_sigma_hat

EPS = np.finfo(float).eps
AGREE = 1e-10  # kernel vs reference, relative to the size of each trajectory (rounding only: ~1e-15 seen)


def model_aware_isl(model: Model, nu: float) -> FilterSpec:
    """An ISL filter propagating with the true A (damp = α), to exercise the damped power-law branch."""
    return FilterSpec("aware", "ISL with A", model.alpha, isl_gains(model.m, nu), True)


@pytest.mark.parametrize(
    "alpha, beta, sigma, m",
    [
        (0.0, 3.0, 5.0, 3),
        (0.5, 3.0, 20.0, 3),
        (0.0, 1.0, 1.0, 1),
        (2.0, 1.0, 0.3, 1),
        (0.0, 2.0, 0.5, 2),
        (1.0, 0.5, 3.0, 2),
        (0.3, 2.0, 7.0, 4),
        (0.0, 0.1, 20.0, 5),
        (25.0, 21.2, 2.0, 5),
        (0.0, 2.0, 0.5, 6),
        (4.0, 30.0, 300.0, 6),
    ],
)
def test_kernel_matches_numpy_reference(alpha, beta, sigma, m):
    model = Model(alpha, beta, sigma, m)
    kb = kalman_bucy(model)
    nu = 0.7 * beta
    extra = (
        model_aware_isl(model, nu),
        FilterSpec("kbf0", "KBF with A0", 0.0, np.array(kb.K), False),
        adaptive_kbf(model, sigma_range=(sigma / 5, sigma / 2), memory=200),
    )  # W < n: both phases of λ_k
    run = simulate(model, nu, T=15.0 / kb.r_min, seed=11, extra=extra)
    n = min(run.N, 1500)
    specs = [optimal_kbf(model, kb), isl_filter(model, nu), *extra]
    X, Z, S = reference_sigma_hat(model, specs, h=run.h, n=n, seed=11)
    assert np.max(np.abs(run.X[: n + 1] - X)) <= AGREE * np.max(np.abs(X))
    for f, track in enumerate(run.tracks):
        assert track.name == specs[f].name
        assert np.max(np.abs(track.estimate[: n + 1] - Z[f])) <= AGREE * np.max(np.abs(Z[f]))
    sigma_hat = run.track("kbf_adaptive").sigma_hat
    assert [tr.sigma_hat is None for tr in run.tracks] == [True] * 4 + [False]
    np.testing.assert_allclose(sigma_hat[: n + 1], S[-1], rtol=AGREE)


def _fresh(model, specs, seed):
    rng = np.random.default_rng(seed)
    x, e0 = draw_start(model, kalman_bucy(model), rng, "stationary")
    return rng, x, np.tile(e0, (len(specs), 1))


def test_chunked_calls_batches_and_burn_match_stored_errors():
    model = Model(0.5, 3.0, 20.0, 3)
    kb = kalman_bucy(model)
    specs = [optimal_kbf(model, kb), isl_filter(model, 3.0)]
    h, n, burn, nb = 0.01, 5000, 137, 7
    batch_len = (n - burn) // nb
    no_sigma = np.empty((nb, 0)), np.empty((0, n + 1))  # σ̂ sums and trajectories: no adaptive filter here
    # one call, trajectories stored
    rng, x, e = _fresh(model, specs, 5)
    X = np.empty((n + 1, 3))
    E = np.empty((2, n + 1, 3))
    X[0], E[:, 0] = x, e
    sq_one = np.zeros((nb, 2, 3))
    grid, bank = Grid(h, model.alpha, model.beta), pack(model, specs)
    stored = Trajectory(True, 0, X, E, no_sigma[1])
    assert advance(x, e, rng, n, 0, grid, model.sigma, bank, Batches(burn, batch_len, sq_one, no_sigma[0]), stored) == n
    # the same run in uneven chunks, nothing stored: only X_m of the truth is advanced
    rng, x, e = _fresh(model, specs, 5)
    sq = np.zeros((nb, 2, 3))
    k = 0
    for todo in (1, 136, 1, 250, 123, 489, 4000):
        assert (
            advance(
                x,
                e,
                rng,
                todo,
                k,
                grid,
                model.sigma,
                bank,
                Batches(burn, batch_len, sq, no_sigma[0]),
                Trajectory.none(2, 0, 3),
            )
            == todo
        )
        k += todo
    assert k == n
    assert x[-1] == X[n, -1]
    np.testing.assert_array_equal(e, E[:, n])
    # batch b holds steps burn + b·L + 1 … burn + (b+1)·L, the last batch the remainder (A.30 by parts); the
    # kernel's sums are flushed every FLUSH steps, so they differ from numpy's only in rounding
    err2 = E[:, 1:] ** 2  # (nf, n, m), row k−1 ↔ step k
    edges = [burn + b * batch_len for b in range(nb)] + [n]
    expected = np.stack([err2[:, lo:hi].sum(axis=1) for lo, hi in itertools.pairwise(edges)])
    np.testing.assert_allclose(sq, expected, rtol=(FLUSH + n / FLUSH) * EPS)
    np.testing.assert_allclose(sq_one, expected, rtol=(FLUSH + n / FLUSH) * EPS)


def test_stored_chunks_can_start_at_an_offset():
    """``Trajectory.first``: a chunk's rows go to ``X[k − first]`` (a buffer reused chunk after chunk)."""
    model = Model(0.0, 2.0, 3.0, 4)
    specs = [isl_filter(model, 2.0)]
    grid, bank = Grid(0.01, model.alpha, model.beta), pack(model, specs)
    rng, x, e = _fresh(model, specs, 3)
    X, E, S = np.empty((301, 4)), np.empty((1, 301, 4)), np.empty((0, 301))
    X[0], E[:, 0] = x, e
    sq, sig = np.zeros((1, 1, 4)), np.empty((1, 0))
    advance(x, e, rng, 300, 0, grid, model.sigma, bank, Batches(0, 300, sq, sig), Trajectory(True, 0, X, E, S))
    rng, x, e = _fresh(model, specs, 3)
    buf_x, buf_e = np.empty((101, 4)), np.empty((1, 101, 4))
    for k0 in (0, 100, 200):
        advance(
            x, e, rng, 100, k0, grid, model.sigma, bank, Batches(0, 300, sq, sig), Trajectory(True, k0, buf_x, buf_e, S)
        )
        np.testing.assert_array_equal(buf_x[1:], X[k0 + 1 : k0 + 101])
        np.testing.assert_array_equal(buf_e[:, 1:], E[:, k0 + 1 : k0 + 101])


def test_kernel_stops_at_the_first_non_finite_step():
    model = Model(0.5, 3.0, 20.0, 3)
    kb = kalman_bucy(model)
    specs = [optimal_kbf(model, kb), isl_filter(model, 3.0)]
    rng, x, e = _fresh(model, specs, 1)
    sq = np.zeros((1, 2, 3))
    done = advance(
        x,
        e,
        rng,
        100_000,
        0,
        Grid(50.0, model.alpha, model.beta),
        model.sigma,
        pack(model, specs),
        Batches(0, 100_000, sq, np.empty((1, 0))),
        Trajectory.none(2, 0, 3),
    )
    assert 0 < done < 100_000
    assert not (np.all(np.isfinite(e)) and np.all(np.isfinite(x[-1])))
