"""The noise laws' tables (isl_core.noise): the Student-t ziggurat's layers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from isl_core.noise import student_table


@pytest.mark.parametrize("dof", [2.1, 3.0, 7.5, 40.0, 1e4])
def test_the_student_ziggurat_has_layers_of_equal_area_under_the_density(dof):
    """Each of the 256 layers (width × height) has the base layer's area v = r·f(r) + ∫_r^∞ f, its inner edge where
    f reaches its top, and the layers stack from f(r) to f(0) = 1 — with f = t_d's density over its value at 0,
    the tail from scipy. A narrower layer, a raised inner edge or a wrong height each breaks one of these."""
    tab = student_table(dof)
    law = stats.t(dof)

    def f(x):
        return law.pdf(x) / law.pdf(0.0)

    width, inner, low, high = tab
    r = inner[0]
    v = r * f(r) + law.sf(r) / law.pdf(0.0)
    assert width[0] * high[0] == pytest.approx(v, rel=1e-12) and high[0] == pytest.approx(f(r), rel=1e-12)
    assert np.allclose(width[1:] * (high[1:] - low[1:]), v, rtol=1e-9, atol=0.0)
    assert width[1] == r and np.array_equal(width[2:], inner[1:-1]) and np.array_equal(low[1:], high[:-1])
    assert np.allclose(f(inner[1:-1]), high[1:-1], rtol=1e-12, atol=0.0)
    assert inner[-1] == 0.0 and high[-1] == 1.0 and np.all(np.diff(inner[:-1]) < 0.0)
