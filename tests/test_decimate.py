"""Min/max display decimation (app.decimate): size bound, endpoints, and the per-bucket envelope contract."""
import numpy as np
import pytest

from app.decimate import DISPLAY_POINTS, minmax, minmax_indices


def _walk(n: int, seed: int = 3) -> np.ndarray:
    return np.cumsum(np.random.default_rng(seed).standard_normal(n))


@pytest.mark.parametrize("n", [1, 2, 10, DISPLAY_POINTS])
def test_short_input_is_returned_whole(n):
    assert np.array_equal(minmax_indices(np.zeros(n)), np.arange(n))


@pytest.mark.parametrize("n, max_points", [(DISPLAY_POINTS + 1, DISPLAY_POINTS), (10_007, 1000), (1_000_000, 2400),
                                           (2_501, 2400), (5_000, 4)])
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
