"""What both compiled loops share: the division-free cube root and the m-th root of the power law, within a few ulp."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isl_core.kernels.common import fast_cbrt
from isl_core.kernels.common import root as _root

EPS = np.finfo(float).eps


def ulps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a - b) / np.spacing(np.abs(b))


def exact_root(a: np.ndarray, m: int) -> np.ndarray:
    """``a^{1/m}`` in extended precision (x87 long double: 64-bit mantissa), rounded to float64."""
    return (a.astype(np.longdouble) ** (np.longdouble(1) / np.longdouble(m))).astype(np.float64)


# the division-free cube root: y ≈ a^{-1/3} to ~3 ulp after two series steps, r = a·y² doubles that and
# adds two roundings
ROOT_ULPS = 8


def test_fast_cbrt_within_a_few_ulp():
    rng = np.random.default_rng(0)
    a = np.concatenate(
        [
            np.exp(rng.uniform(-690.0, 690.0, 20_000)),
            rng.uniform(0.0, 10.0, 20_000),
            [1.0, 8.0, 27.0, 1e-299, 9.9e299, 2.0**-1022, 0.125],
        ]
    )
    a = a[a > 0]
    got = np.array([fast_cbrt(x) for x in a])
    assert ulps(got, exact_root(a, 3)).max() <= ROOT_ULPS
    assert ulps(got, np.cbrt(a)).max() <= ROOT_ULPS + 1


@pytest.mark.parametrize("a", [1e-310, 5e-324, 1e300, 1.7e308])
def test_fast_cbrt_edges(a):
    assert ulps(np.array(fast_cbrt(a)), np.cbrt(a)) <= 2  # left to the compiled libm route


@pytest.mark.parametrize("a, expected", [(0.0, 0.0), (math.inf, math.inf), (8.0, 2.0), (0.125, 0.5)])
def test_fast_cbrt_special_values(a, expected):
    assert fast_cbrt(a) == pytest.approx(expected, rel=ROOT_ULPS * EPS)


def test_fast_cbrt_nan():
    assert math.isnan(fast_cbrt(math.nan))


@pytest.mark.parametrize("m", range(1, 7))
def test_root_is_the_mth_root(m):
    a = np.exp(np.random.default_rng(m).uniform(-50.0, 50.0, 2000))
    got = np.array([_root(x, m) for x in a])
    assert ulps(got, exact_root(a, m)).max() <= ROOT_ULPS
