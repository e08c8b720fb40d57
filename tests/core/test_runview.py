"""Runs decimated while they are simulated (isl_core.runview): the same run as simulate, drawn from little memory."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from isl_core import Model, adaptive_kbf, simulate
from isl_core.decimate import minmax_indices
from isl_core.runview import TUBE_THEORY, simulate_view

FIG3 = Model(0.5, 3.0, 20.0, 3)
BATCHES = 50  #: batch means of the tube test: enough for its sd, each batch ≫ the error's correlation time


@pytest.mark.parametrize(
    "model, horizon, points",
    [
        (FIG3, 10.0, 2400),
        (FIG3, 300.0, 400),
        (Model(0.0, 1.0, 5.0, 6), 40.0, 1000),
        (Model(1.0, 0.5, 3.0, 1), 50.0, 64),
    ],
)
def test_the_view_is_the_simulated_run_decimated(model, horizon, points):
    extra = [adaptive_kbf(model, sigma_range=(1.0, 30.0), memory=100)]
    run = simulate(model, 0.7 * model.beta, horizon=horizon, seed=5, extra=extra)
    view = simulate_view(model, 0.7 * model.beta, horizon=horizon, seed=5, extra=extra, points=points)
    assert (view.N, view.h, view.T, view.stretch) == (run.N, run.h, run.T, run.stretch)
    assert [tr.name for tr in view.tracks] == [tr.name for tr in run.tracks]
    for i in range(model.m):
        k = minmax_indices(run.X[:, i], points)
        np.testing.assert_array_equal(view.truth[i].y, run.X[k, i])
        np.testing.assert_array_equal(view.truth[i].t, run.t[k])
        for full, dec in zip(run.tracks, view.tracks, strict=True):
            est = full.estimate[:, i]
            np.testing.assert_array_equal(dec.estimate[i].y, est[minmax_indices(est, points)])
            np.testing.assert_array_equal(dec.error[i].y, full.error[minmax_indices(full.error[:, i], points), i])
    for full, dec in zip(run.tracks, view.tracks, strict=True):
        np.testing.assert_allclose(dec.rmse, full.rmse, rtol=1e-12)  # the same squares, summed in other chunks
        inside = np.mean(np.abs(full.error[1:]) <= 3.0 * run.s, axis=0)
        np.testing.assert_array_equal(dec.inside, inside)
    sig = view.track("kbf_adaptive").sigma_hat
    full_sig = run.track("kbf_adaptive").sigma_hat
    np.testing.assert_array_equal(sig.y, full_sig[minmax_indices(full_sig, points)])
    assert view.track("kbf_adaptive").sigma_hat_mean == pytest.approx(full_sig[1:].mean(), rel=1e-12)


def test_a_long_view_needs_little_memory():
    """10⁶ steps at m = 6 with the optimal and the ISL filter: the full run holds ≈ 144 MB of trajectories; the view
    peaks at its chunk buffers (a few MB)."""
    model = Model(1.0, 1.0, 1.0, 6)
    simulate_view(model, 50.0, T=1.0)  # compiled, warm
    tracemalloc.start()
    view = simulate_view(model, 50.0, horizon=1000.0, seed=1)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    full_bytes = 8 * (view.N + 1) * model.m * (1 + len(view.tracks))
    assert view.N > 300_000 and peak < 30 * 2**20 and peak < full_bytes / 4, (view.N, peak, full_bytes)


def test_the_optimal_filter_keeps_the_signal_in_its_tube_as_theory_says():
    """Over a long run the signal spends 99.73 % of the time inside X̂ ± 3 s (a Gaussian error of sd s_i). The steps
    outside are a binomial count made of correlated steps: the sd of their fraction is read from the run's own
    batch means (BATCHES of them), and the fraction is within four of those sd of the theory's."""
    assert pytest.approx(0.9973, abs=1e-4) == TUBE_THEORY
    run = simulate(FIG3, 3.0, horizon=5000.0, seed=2)
    outside = np.abs(run.tracks[0].error[1:]) > 3.0 * run.s
    batches = outside[: len(outside) // BATCHES * BATCHES].reshape(BATCHES, -1, FIG3.m).mean(axis=1)
    sd = batches.std(axis=0, ddof=1) / np.sqrt(BATCHES)
    inside = 1.0 - outside.mean(axis=0)
    assert np.all(sd < 0.25 * (1.0 - TUBE_THEORY)), sd  # the run is long enough to tell the fraction apart from 0
    assert np.all(np.abs(inside - TUBE_THEORY) <= 4.0 * sd), (inside, sd)
