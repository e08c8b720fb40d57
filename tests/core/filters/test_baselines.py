"""The baselines of a user without σ (:mod:`isl_core.filters.baselines`): the registry, its names and defaults, the
theory per filter. The filters themselves are tested by family (``test_kalman``, ``test_isl``, ``test_adaptive``).

Statistics: ratios come with batch-means Student intervals (:func:`isl_core.sweep.ratio_interval`) at LEVEL.
Fixed-gain filters are linear, so the stationary covariance of their Euler recursion
(``predicted_covariance(..., h=run.h)``) is *exact* for the simulated scheme: simulation must cover it.
It differs from the continuous Lyapunov answer (:ref:`theory`) by O(h·rate), checked separately.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from isl_core import Model, isl_filter, kalman_bucy
from isl_core.filters.base import KIND_ADAPTIVE, KIND_LINEAR, KIND_POWER
from isl_core.filters.baselines import BASELINES, LABELS, baseline_filters
from isl_core.filters.kalman import design_sigma, minimax_kbf, mismatched_kbf
from isl_core.theory import mismatched_kbf_ratios, predicted_ratios_grid, theory_ratios

EPS = np.finfo(float).eps
LEVEL = 0.99
FIG3 = Model.from_w(0.5, 3.0, 20.0, 3)


# -------------------------------------------------------------------------------------------- the registry


def test_registry_names_kinds_and_defaults():
    specs = baseline_filters(FIG3, nu=3.0, sigma_range=(2.0, 200.0))
    assert tuple(s.name for s in specs) == BASELINES and set(LABELS) == set(BASELINES)
    by = {s.name: s for s in specs}
    assert [by[n].kind for n in BASELINES] == [
        KIND_LINEAR,
        KIND_POWER,
        KIND_LINEAR,
        KIND_LINEAR,
        KIND_ADAPTIVE,
        KIND_POWER,
    ]
    assert [by[n].damp for n in BASELINES] == [FIG3.alpha, 0.0, FIG3.alpha, FIG3.alpha, FIG3.alpha, FIG3.alpha]
    assert design_sigma((2.0, 200.0)) == pytest.approx(20.0, rel=4 * EPS)  # the geometric middle
    np.testing.assert_array_equal(by["kbf_mismatched"].coef, mismatched_kbf(FIG3, design_sigma((2.0, 200.0))).coef)
    np.testing.assert_array_equal(by["kbf_minimax"].coef, mismatched_kbf(FIG3, 200.0).coef)
    np.testing.assert_array_equal(by["isl_model"].coef, by["isl"].coef)  # same φ, only the propagation differs
    np.testing.assert_array_equal(by["kbf"].coef, kalman_bucy(FIG3).K)
    picked = baseline_filters(FIG3, nu=3.0, nu_model=1.5, sigma_design=7.0, names=("isl_model", "kbf_mismatched"))
    assert [s.name for s in picked] == ["isl_model", "kbf_mismatched"]
    np.testing.assert_array_equal(picked[0].coef, isl_filter(FIG3, 1.5).coef)
    np.testing.assert_array_equal(picked[1].coef, mismatched_kbf(FIG3, 7.0).coef)
    np.testing.assert_array_equal(minimax_kbf(FIG3, (1.0, 50.0)).coef, mismatched_kbf(FIG3, 50.0).coef)


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        ({"names": ("kbf", "nope")}, r"^names must be a non-empty sequence of distinct names from"),
        ({"names": ("kbf", "kbf")}, r"^names must be"),
        ({"names": ()}, r"^names must be"),
        ({"names": "kbf"}, r"^names must be"),
        ({"sigma_range": (5.0, 2.0)}, r"^sigma_range\[1\] must be a finite number >= 5"),
        ({"sigma_range": 3.0}, r"^sigma_range must be a pair"),
        ({"sigma_range": (0.0, 2.0)}, r"^sigma_range\[0\] must be a finite number > 0"),
        ({"memory": 0.5}, r"^memory \(W, in sensor readings\) must be a finite number >= 1"),
        ({"sigma_design": math.nan, "names": ("kbf_mismatched",)}, r"^sigma_design must be a finite number > 0"),
        ({"nu": -1.0, "names": ("isl",)}, r"^nu must be a finite number > 0"),
    ],
)
def test_registry_rejects_bad_input(kwargs, pattern):
    kwargs = {"nu": 3.0, **kwargs}
    with pytest.raises(ValueError, match=pattern):
        baseline_filters(FIG3, **kwargs)


def test_theory_per_filter():
    """Fixed gains: the mismatched-gain Lyapunov equation (:ref:`mismatched-kbf`); oracle 1; adaptive: no theory
    (nan)."""
    specs = {s.name: s for s in baseline_filters(FIG3, nu=3.0, sigma_design=5.0)}
    np.testing.assert_allclose(theory_ratios(FIG3, specs["kbf"]), 1.0, rtol=1e-9)
    np.testing.assert_allclose(
        theory_ratios(FIG3, specs["kbf_mismatched"]), mismatched_kbf_ratios(FIG3, 5.0), rtol=1e-12
    )
    np.testing.assert_allclose(
        theory_ratios(FIG3, specs["isl_model"]), predicted_ratios_grid(FIG3, [3.0], damp=FIG3.alpha)[0], rtol=1e-12
    )
    assert np.all(np.isnan(theory_ratios(FIG3, specs["kbf_adaptive"])))
