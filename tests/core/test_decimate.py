"""Min/max display decimation (isl_core.decimate): size bound, endpoints, and the per-bucket envelope contract."""

import numpy as np
import pytest

from isl_core.decimate import DISPLAY_POINTS, MinMax, minmax, minmax_indices


def _walk(n: int, seed: int = 3) -> np.ndarray:
    return np.cumsum(np.random.default_rng(seed).standard_normal(n))


@pytest.mark.parametrize("n", [1, 2, 10, DISPLAY_POINTS])
def test_short_input_is_returned_whole(n):
    assert np.array_equal(minmax_indices(np.zeros(n)), np.arange(n))


@pytest.mark.parametrize(
    "n, max_points",
    [(DISPLAY_POINTS + 1, DISPLAY_POINTS), (10_007, 1000), (1_000_000, 2400), (2_501, 2400), (5_000, 4)],
)
def test_size_bound_endpoints_and_order(n, max_points):
    y = _walk(n)
    k = minmax_indices(y, max_points)
    assert len(k) <= max_points
    assert k[0] == 0 and k[-1] == n - 1
    assert np.all(np.diff(k) > 0)


@pytest.mark.parametrize("n, max_points", [(10_007, 1000), (123_457, 2400), (2_501, 2400)])
def test_every_bucket_keeps_its_min_and_max(n, max_points):
    """The documented contract: interior cut into (max_points − 2)//2 buckets of ⌈(n−2)/B⌉ samples."""
    y = _walk(n)
    kept = set(minmax_indices(y, max_points).tolist())
    size = -(-(n - 2) // ((max_points - 2) // 2))
    for a in range(1, n - 1, size):
        b = min(a + size, n - 1)
        assert a + int(np.argmin(y[a:b])) in kept
        assert a + int(np.argmax(y[a:b])) in kept
    assert int(np.argmax(y)) in kept and int(np.argmin(y)) in kept


def test_minmax_returns_real_samples():
    t = np.linspace(0.0, 50.0, 20_001)
    y = _walk(len(t))
    td, yd = minmax(t, y, 500)
    k = np.searchsorted(t, td)
    assert np.array_equal(t[k], td) and np.array_equal(y[k], yd)
    assert yd.max() == y.max() and yd.min() == y.min()


def test_too_few_points_is_refused():
    with pytest.raises(ValueError, match="max_points"):
        minmax_indices(np.zeros(100), 3)


@pytest.mark.parametrize(
    "n, max_points",
    [
        (2, 2400),
        (3, 2400),
        (10, 2400),
        (2_400, 2400),
        (2_401, 2400),
        (10_007, 1000),
        (123_457, 2400),
        (5_000, 4),
        (5, 4),
        (99_999, 2400),
    ],
)
@pytest.mark.parametrize("blocks", ["one", "random", "tiny"])
def test_block_by_block_keeps_exactly_what_the_whole_trace_keeps(n, max_points, blocks):
    rng = np.random.default_rng(n)
    Y = np.stack([_walk(n, seed) for seed in range(3)] + [np.round(_walk(n, 9))], axis=1)  # rounded: many ties
    red = MinMax(n, Y.shape[1], max_points)
    cuts = {"one": [n], "random": rng.integers(1, 5000, size=n).tolist(), "tiny": [1, 2, 3] * n}[blocks]
    k = 0
    for size in cuts:
        if k >= n:
            break
        red.add(Y[k : k + size])
        k += size
    for j in range(Y.shape[1]):
        idx, val = red.result(j)
        expected = minmax_indices(Y[:, j], max_points)
        np.testing.assert_array_equal(idx, expected)
        np.testing.assert_array_equal(val, Y[expected, j])


def test_a_short_trace_comes_back_whole_but_for_a_nan_sample():
    """A trace of at most max_points samples is kept whole (each bucket one sample); a nan sample is neither below
    nor above anything, so its bucket keeps no sample and it is left out, never shown as the bucket's ±inf."""
    red = MinMax(5, 2)
    red.add(np.array([[0.0, 0.0], [1.0, 1.0], [np.nan, 2.0], [3.0, 3.0], [4.0, 4.0]]))
    idx, val = red.result(0)
    np.testing.assert_array_equal(idx, [0, 1, 3, 4])
    np.testing.assert_array_equal(val, [0.0, 1.0, 3.0, 4.0])
    idx, val = red.result(1)
    np.testing.assert_array_equal(idx, np.arange(5))
    np.testing.assert_array_equal(val, np.arange(5.0))


def test_block_reducer_refuses_misuse():
    red = MinMax(10_000, 2, 100)
    with pytest.raises(ValueError, match="only 0 of 10000 samples"):
        red.result(0)
    with pytest.raises(ValueError, match=r"expected rows 0..9999 of 2 traces"):
        red.add(np.zeros((5, 3)))
