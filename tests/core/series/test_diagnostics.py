"""Every filter over a series and the diagnostics without a truth: on readings drawn from the model itself, the
filter at the true parameters is consistent (NIS in its interval) and the fit finds the parameters it drew from."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("statsmodels", reason="the data extra: pip install 'isl[data]'")

from isl_core.series import SERIES_FILTERS, ReadingModel, fit, run_filters, series
from isl_core.series.diagnostics import diagnose, judge
from isl_core.series.discretize import van_loan

TRUE = ReadingModel(2, 0.3, 0.4, 1.5)
N = 3000


def _draw(rm: ReadingModel, n: int, seed: int, dt: float = 0.5):
    F, Q = van_loan(rm.m, rm.alpha, rm.beta, np.array([dt]))
    rng = np.random.default_rng(seed)
    w = rng.standard_normal((n, rm.m)) @ np.linalg.cholesky(Q[0]).T
    x = np.zeros((n, rm.m))
    for k in range(1, n):
        x[k] = F[0] @ x[k - 1] + w[k]
    z = x[:, 0] + rm.sigma_r * rng.standard_normal(n)
    z[rng.choice(n, n // 50, replace=False)] = np.nan  # 2 % missing
    return series(dt * np.arange(n), z), x


@pytest.fixture(scope="module")
def drawn():
    return _draw(TRUE, N, seed=3)


def test_the_fit_finds_the_parameters_it_drew_from(drawn):
    """Each fitted parameter within 4 of its own standard errors of the truth (the SE is the sample's tolerance)."""
    s, _ = drawn
    f = fit(s, 2)
    for est, se, true in zip((f.params.alpha, f.params.beta, f.params.sigma_r), f.se, (0.3, 0.4, 1.5), strict=True):
        assert math.isfinite(se) and se > 0
        assert abs(est - true) < 4.0 * se, (est, se, true)
    assert f.sigma == pytest.approx(f.params.sigma_r * math.sqrt(0.5))
    assert f.aic == pytest.approx(6.0 - 2.0 * f.loglik) and f.n == int(s.present.sum()) - 2


def test_every_filter_runs_and_the_kalman_filter_is_consistent(drawn):
    s, x = drawn
    run = run_filters(s, TRUE)
    assert [t.name for t in run.tracks] == list(SERIES_FILTERS)
    tail = np.arange(s.n) >= 500
    for tr in run.tracks:
        assert tr.estimate.shape == (N, 2) and np.all(np.isfinite(tr.estimate))
        err = np.sqrt(np.mean((tr.estimate[tail, 0] - x[tail, 0]) ** 2))
        assert err < TRUE.sigma_r, (tr.name, err)  # every filter smooths: its error is below a reading's
    d = diagnose(run.track("kalman"), tail)
    lo, hi = d.nis_interval
    assert lo < d.nis < hi and d.ljung_box_p > 1e-3 and math.isfinite(d.predictive_loglik)
    # the Kalman filter at the true parameters predicts best of all that state a variance (on average)
    stated = [diagnose(t, tail) for t in run.tracks if t.name in ("kalman", "kbf_adaptive", "vb", "imm")]
    assert max(stated, key=lambda x: x.predictive_loglik).predictive_loglik < d.predictive_loglik + 5.0


def test_judge_holds_out_the_tail_and_chooses_m(drawn):
    s, _ = drawn
    j = judge(s.head(1200), holdout=0.25)
    assert j.split == 900 and len(j.orders) == 6 and j.fit.params.m == min(j.orders, key=lambda f: f.bic).params.m
    assert all(f.burn == 6 for f in j.orders)
    isl = next(d for d in j.diagnostics if d.name == "isl")
    assert math.isnan(isl.nis) and "no variance" in isl.note and math.isfinite(isl.rmse)


def test_judge_refuses_a_holdout_that_leaves_too_few(drawn):
    s, _ = drawn
    with pytest.raises(ValueError, match="holdout must"):
        judge(s.head(30), m=1, holdout=0.9)


_RNG = np.random.default_rng(0)
_N = 60


@pytest.mark.parametrize(
    ("t", "z", "refusal"),
    [
        (np.arange(60.0), np.ones(_N), "the readings are all equal"),
        (1e-200 * np.arange(60.0), _RNG.standard_normal(_N), "typical interval between times must lie in"),
        (np.arange(60.0), 1e140 * _RNG.standard_normal(_N), None),
        (1e12 + np.arange(60.0), _RNG.standard_normal(_N), None),
        (np.cumsum(10 ** _RNG.uniform(-6, 6, _N)), _RNG.standard_normal(_N), None),
        (np.arange(60.0), np.r_[np.zeros(30), 1e6 * np.ones(30)], None),
    ],
    ids=["constant", "tiny-interval", "huge-values", "late-times", "wild-intervals", "a-step"],
)
def test_extreme_series_get_a_judgement_or_a_reason(t, z, refusal):
    """Units far from 1 are taken out before the filters run (their spread and the typical interval): a result, or a
    ValueError that says why — never an overflow (warnings are errors in the tests)."""
    if refusal is not None:
        with pytest.raises(ValueError, match=refusal):
            judge(series(t, z), m=2)
        return
    j = judge(series(t, z), m=2)
    # every filter's prediction RMSE a finite number (a constant tail: 0 is fair), never an overflow's inf or a NaN
    assert np.isfinite(j.fit.loglik) and all(np.isfinite(d.rmse) and d.rmse >= 0 for d in j.diagnostics)
    kalman = j.diagnostics[0]
    assert np.isfinite(kalman.nis) and kalman.nis >= 0
