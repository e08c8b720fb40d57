"""The compiled filters over a series against plain-NumPy references of their documented update: propagate with
expm(A_f Δ), u = √Δ (z − Ẑ₁), Ẑ += √Δ φ(u) — φ the power law (ISL), K(σ̂)·u (adaptive) or K(σ̂)·ψ(u) (robust), σ̂ from
the running variance of u with λ = max(1/r, 1/W) and Mehra's correction."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm

from isl_core import isl_exponents, phi
from isl_core.filters.robust import huber_kappa
from isl_core.series import ReadingModel, run_filters, series
from isl_core.series.run import series_specs, sigma_range

RM = ReadingModel(3, 0.4, 0.6, 0.8)


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(11)
    n = 300
    t = np.cumsum(rng.uniform(0.05, 0.3, n))
    z = np.cumsum(np.cumsum(rng.standard_normal(n))) * 0.01 + 0.8 * rng.standard_normal(n)
    z[[0, 40, 41, 200]] = np.nan  # the first time without a reading too
    return series(t, z)


def _reference(s, spec):
    m = spec.coef.shape[0]
    A = np.eye(m, k=1)
    A[-1, -1] = -spec.damp
    k0 = int(np.flatnonzero(s.present)[0])
    x = np.zeros(m)
    x[0] = s.z[k0]
    est = np.full((s.n, m), np.nan)
    est[k0] = x
    ad = spec.adaptive
    v = None if ad is None else ad.sigma_init**2
    sig = None if ad is None else ad.sigma_init
    r = 0
    for k in range(k0 + 1, s.n):
        dt = s.t[k] - s.t[k - 1]
        x = expm(A * dt) @ x
        if np.isfinite(s.z[k]):
            u = math.sqrt(dt) * (s.z[k] - x[0])
            if ad is None:
                x = x + math.sqrt(dt) * phi(u, spec.coef, spec.exponents())
            else:
                r += 1
                K = ad.gain(sig)
                lim = (spec.huber or 0.0) * sig
                p = u if spec.huber is None else min(max(u, -lim), lim)
                x = x + math.sqrt(dt) * K * p
                uu = u * u if spec.huber is None else min(u * u, lim * lim) / huber_kappa(spec.huber)
                v += max(1.0 / r, 1.0 / ad.memory) * (uu - v)
                sig = math.sqrt(v / (1.0 + dt * K[0]))
        est[k] = x
    return est


@pytest.mark.parametrize("name", ["isl", "isl_model", "kbf_adaptive", "kbf_robust"])
def test_compiled_filters_equal_their_reference(data, name):
    spec = series_specs(RM.model(data.spacing), RM.beta, sigma_range(data), 1000.0, [name])[name]
    assert spec.exponents().tolist() == (isl_exponents(3) if spec.power else np.ones(3)).tolist()
    got = run_filters(data, RM, names=[name]).track(name).estimate
    # the compiled power law's cube root is a few ulp from libm's and a*b + c is fused: 300 nonlinear steps apart
    np.testing.assert_allclose(got, _reference(data, spec), rtol=1e-7, atol=1e-10)
