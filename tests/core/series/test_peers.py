"""The likelihood and the fit against statsmodels: the local level on the Nile (m = 1, α = 0), and the general
state-space model (``MLEModel``) built with the same matrices on 50 random models."""

from __future__ import annotations

import math

import numpy as np
import pytest

sm = pytest.importorskip("statsmodels.api", reason="the data extra: pip install 'isl[data]'")

from isl_core.series import ReadingModel, fit, loglik, series  # noqa: E402
from isl_core.series.discretize import steps, van_loan  # noqa: E402
from isl_core.series.likelihood import kalman_track  # noqa: E402


@pytest.fixture(scope="module")
def nile():
    data = sm.datasets.nile.load_pandas().data
    return series(data["year"].to_numpy(float), data["volume"].to_numpy(float), name="nile", unit="year")


def test_nile_local_level_equals_statsmodels(nile):
    """Exact diffuse local level: parameters (σ_r² = irregular, β²Δ = level) and log L to 1e-4 relative; log L at the
    same parameters to 1e-9; standard errors as statsmodels' numerical Hessian (delta method) to 1e-2."""
    mod = sm.tsa.UnobservedComponents(nile.z, "local level", use_exact_diffuse=True)
    ref = mod.fit(disp=False, method="nm", maxiter=5000, xtol=1e-10, ftol=1e-12)
    ref = mod.fit(ref.params, disp=False, method="bfgs", gtol=1e-9, cov_type="approx")
    ours = fit(nile, 1, alpha=0.0)
    p = ours.params
    np.testing.assert_allclose([p.sigma_r**2, p.beta**2], ref.params, rtol=1e-4)
    assert ours.loglik == pytest.approx(ref.llf, rel=1e-4)
    at = loglik(nile, ReadingModel(1, 0.0, math.sqrt(ref.params[1]), math.sqrt(ref.params[0])))
    assert at == pytest.approx(ref.llf, rel=1e-9)
    se_var = [2.0 * p.sigma_r * ours.se[2], 2.0 * p.beta * ours.se[1]]  # d(x²) = 2x dx
    np.testing.assert_allclose(se_var, ref.bse, rtol=1e-2)


class _Same(sm.tsa.statespace.MLEModel):
    """statsmodels' general state-space model with our F_k, Q_k, σ_r² and a known start."""

    def __init__(self, z, F, Q, r, x0, P0):
        m = F.shape[1]
        super().__init__(z, k_states=m, k_posdef=m)
        self["design"] = np.eye(1, m)
        self["obs_cov"] = [[r]]
        self["transition"] = np.ascontiguousarray(np.transpose(F, (1, 2, 0)))
        self["selection"] = np.eye(m)
        self["state_cov"] = np.ascontiguousarray(np.transpose(Q, (1, 2, 0)))
        self.ssm.initialize_known(x0, P0)


def _random_case(seed: int):
    rng = np.random.default_rng(seed)
    m = int(rng.integers(1, 7))
    alpha = 0.0 if seed % 4 == 0 else float(rng.uniform(0.01, 3.0))
    rm = ReadingModel(m, alpha, float(rng.uniform(0.1, 3.0)), float(rng.uniform(0.2, 5.0)))
    n = 60
    t = np.cumsum(rng.uniform(0.05, 0.5, n)) if seed % 2 else 0.2 * np.arange(n)
    z = np.cumsum(rng.standard_normal(n)) + rng.standard_normal(n)
    z[rng.choice(n, 5, replace=False)[1:]] = np.nan
    G = rng.standard_normal((m, m))
    return series(t, z), rm, rng.standard_normal(m), G @ G.T + np.eye(m)


@pytest.mark.parametrize("seed", range(50))
def test_loglik_equals_statsmodels_mlemodel(seed):
    """Any m, α (α = 0 in a quarter), irregular times in half, missing readings, a known start: log L to 1e-8."""
    s, rm, x0, P0 = _random_case(seed)
    st = steps(s.t)
    F, Q = van_loan(rm.m, rm.alpha, rm.beta, st.dt)
    idx = st.index[1:]
    Fk, Qk = np.concatenate([F[idx], F[idx[-1:]]]), np.concatenate([Q[idx], Q[idx[-1:]]])
    ref = _Same(s.z, Fk, Qk, rm.sigma_r**2, x0, P0).loglike([])
    assert loglik(s, rm, start=(x0, P0)) == pytest.approx(ref, rel=1e-8)


def test_kalman_estimates_equal_statsmodels_filtered_states():
    s, rm, x0, P0 = _random_case(7)
    st = steps(s.t)
    F, Q = van_loan(rm.m, rm.alpha, rm.beta, st.dt)
    idx = st.index[1:]
    Fk, Qk = np.concatenate([F[idx], F[idx[-1:]]]), np.concatenate([Q[idx], Q[idx[-1:]]])
    res = _Same(s.z, Fk, Qk, rm.sigma_r**2, x0, P0).filter([])
    _, est, _, pred, svar = kalman_track(s, rm, start=(x0, P0))
    scale = np.abs(res.filtered_state).max()
    np.testing.assert_allclose(est, res.filtered_state.T, rtol=1e-9, atol=1e-10 * scale)
    np.testing.assert_allclose(pred, res.forecasts[0], rtol=1e-9, atol=1e-10 * scale)
    np.testing.assert_allclose(svar, res.forecasts_error_cov[0, 0], rtol=1e-9)
