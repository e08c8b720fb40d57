"""The noise laws as the compiled loops draw them (isl_core.kernels.draws): variances, the t law's tails, the outliers'
steps."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from isl_core.noise import student_table
from isl_core.scenario import Scenario


@pytest.mark.parametrize(
    ("scenario", "variance"),
    [
        (Scenario(noise="student", dof=3.0), 1.0),
        (Scenario(noise="student", dof=10.0), 1.0),
        (Scenario(noise="outliers", outlier_rate=0.01, outlier_scale=30.0), 0.99 + 0.01 * 900.0),
    ],
)
def test_noise_laws_have_the_documented_variance(scenario, variance):
    eps = scenario.draw_noise(np.random.default_rng(7), 400_000)
    assert scenario.noise_variance == pytest.approx(variance)
    # 6 standard errors of the sample variance (its fourth moment measured; for t_3 it is infinite, so the
    # batch of 400 000 only bounds it loosely: use the median-based check below instead)
    if scenario.noise == "student" and scenario.dof <= 4:
        # t_3 scaled to unit variance: its median |ε| is √(1/3)·0.7649 (the t_3 quartile)
        assert np.median(np.abs(eps)) == pytest.approx(math.sqrt(1 / 3) * 0.764892, rel=0.01)
    else:
        se = np.std(eps**2) / math.sqrt(len(eps))
        assert abs(np.mean(eps**2) - variance) < 6 * se
    if scenario.noise == "outliers":
        assert np.mean(np.abs(eps) > 8.0) == pytest.approx(0.01 * math.erfc(8 / 30 / math.sqrt(2)), rel=0.1)


@pytest.mark.parametrize("dof", [2.1, 3.0, 7.5, 40.0])
def test_student_noise_has_the_t_law_in_the_tails_too(dof):
    """The ziggurat's draws against scipy's t_d: the whole law (Kolmogorov–Smirnov, 10⁶ draws; a layer's wrong edge
    or height moves the statistic far beyond its 1e-4 quantile) and the two tails where a heavy-tailed law differs
    from a Gaussian of the same variance: beyond the 10⁻³ quantile, and beyond the 10⁻⁴ one, past the ziggurat's
    base edge r, drawn from its envelope there (a tail cut at the base layer's width leaves none)."""
    scale = math.sqrt((dof - 2.0) / dof)
    t = Scenario(noise="student", dof=dof).draw_noise(np.random.default_rng(3), 1_000_000) / scale
    assert stats.kstest(t, stats.t(dof).cdf).pvalue > 1e-4
    for p, tolerance in ((1e-3, 0.1), (1e-4, 0.35)):  # about 3.2 and 3.5 standard errors (2000 and 200 expected)
        far = stats.t(dof).isf(p / 2.0)
        assert np.mean(np.abs(t) > far) == pytest.approx(p, rel=tolerance)
    assert stats.t(dof).isf(5e-5) > student_table(dof)[1, 0]  # the second tail is beyond r


@pytest.mark.parametrize("rate", [0.3, 0.01])
def test_outliers_fall_on_independent_steps_at_the_rate(rate):
    """Each step is an outlier with probability p, independently (isl_core.noise): the rate, the rate of two in a
    row (p²) and the first step's rate over many runs — each within 4 standard errors."""
    scenario = Scenario(noise="outliers", outlier_rate=rate, outlier_scale=3.0)
    unscaled = Scenario(noise="outliers", outlier_rate=rate, outlier_scale=1.0)  # the same draws, k = 1

    def outliers(seed, n):  # exactly the steps scaled by k: which ones does not depend on k
        drawn, plain = (s.draw_noise(np.random.default_rng(seed), n) for s in (scenario, unscaled))
        assert np.all((drawn == plain) | (drawn == 3.0 * plain))  # every ε is N(0,1) or k times it
        return drawn != plain

    hit = outliers(5, 400_000)
    n = hit.size

    def close(x, p, m):
        return abs(x - p) < 4.0 * math.sqrt(p * (1.0 - p) / m)

    assert close(hit.mean(), rate, n) and close(np.mean(hit[1:] & hit[:-1]), rate * rate, n)
    first = [outliers(seed, 1)[0] for seed in range(4000)]
    assert close(np.mean(first), rate, 4000)
