"""Computed ν recommendation (A.31, :ref:`worst-case`): optimal in theory, no worse than the paper's table in
simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _reference import worst_fixed_gain

from isl_core import Sampling
from isl_core.recommend import recommend_nu, worst_case_theory
from isl_core.sweep import FIG2_SIGMAS

#: Paper A, table (A.31): ν/β read off Fig. 2 by eye — used here only as the comparison point.
PAPER_A31 = {0.04: 1.0, 0.2: 0.7, 1.0: 0.2, 5.0: 0.03, 25.0: 0.01}


@pytest.mark.parametrize("alpha", [0.04, 0.2, 1.0, 5.0, pytest.param(25.0, marks=pytest.mark.slow)])
def test_recommendation_no_worse_than_paper_table(alpha):
    """Both ν simulated on the same noise, worst case over σ ∈ {2, 20, 200} and i, m = 3, w = 3.

    The recommended ν's worst-case ratio may exceed the table's only by the two 95 % half-widths.
    """
    sampling = Sampling(seeds=(21, 22), horizon=300.0, batches=8)
    rec = recommend_nu(alpha, sigmas=FIG2_SIGMAS, m=3, w=3.0, compare=[PAPER_A31[alpha]], sampling=sampling)
    (paper,) = rec.compared
    assert paper.nu_over_beta == PAPER_A31[alpha]
    tol = (rec.simulated_high - rec.simulated_low) / 2 + (paper.high - paper.low) / 2
    assert rec.simulated_worst <= paper.simulated + tol, (alpha, rec.simulated_worst, paper.simulated)
    assert rec.theory_worst <= paper.theory


@pytest.mark.parametrize("alpha", [0.04, 1.0, 25.0])
def test_recommendation_minimises_the_predicted_worst_case(alpha):
    rec = recommend_nu(alpha, verify=False)
    assert rec.nu == pytest.approx(rec.beta * rec.nu_over_beta) and rec.beta == pytest.approx(3 * math.sqrt(2 * alpha))
    assert rec.theory_worst == pytest.approx(float(worst_case_theory(alpha, rec.nu_over_beta)))
    ell = math.log2(rec.nu_over_beta)
    around = worst_case_theory(alpha, 2.0 ** (ell + np.array([-0.01, 0.01])))
    assert np.all(rec.theory_worst <= around + 1e-12)
    grid = worst_case_theory(alpha, 2.0 ** np.linspace(-12, 4, 321))
    assert rec.theory_worst <= grid.min() + 1e-12
    assert rec.worst_sigma in FIG2_SIGMAS and 1 <= rec.worst_i <= 3
    assert math.isnan(rec.simulated_worst)


def test_verified_recommendation_beats_the_best_fixed_kalman_bucy():
    """Verified by simulation: measured ≈ predicted worst case, and far below the fixed-gain baseline ≈ 2.9."""
    rec = recommend_nu(1.0, sampling=Sampling(seeds=(1, 2), horizon=300.0, batches=8))
    assert rec.simulated_low <= rec.simulated_worst <= rec.simulated_high
    half = (rec.simulated_high - rec.simulated_low) / 2
    assert abs(rec.simulated_worst - rec.theory_worst) <= half + 0.05 * rec.theory_worst
    # the best fixed gain on the design grid of best_fixed_kbf (49 log-spaced σ̄ over Fig. 2's σ range), written out
    # with scipy (tests/_reference.py), and the paper's 2.9 to the digit it gives
    designs = np.geomspace(min(FIG2_SIGMAS), max(FIG2_SIGMAS), 49)
    assert rec.kbf_worst == pytest.approx(worst_fixed_gain(1.0, 3.0, 3, FIG2_SIGMAS, designs), rel=1e-9)
    assert abs(rec.kbf_worst - 2.9) < 0.05 and rec.kbf_sigma_design in designs
    assert rec.simulated_high < rec.kbf_worst


@pytest.mark.parametrize(
    "kw, name",
    [
        (dict(alpha=0.0), "alpha"),
        (dict(alpha=math.nan), "alpha"),
        (dict(sigmas=[]), "sigmas"),
        (dict(sigmas=[-2.0]), "sigmas"),
        (dict(m=0), "m"),
        (dict(w=-1.0), "w"),
    ],
)
def test_bad_arguments_name_the_parameter(kw, name):
    args = dict(alpha=1.0, verify=False) | kw
    with pytest.raises(ValueError, match=name):
        recommend_nu(args.pop("alpha"), **args)
