"""A reading rate that is physics (isl_core.scenario.presets.at_rate, isl_core.scenario_grid's refine): every filter
reads the sensor R times per 1/r_min whatever the Euler step, a halved step sees the same noise's path, and the
table's cells do not move when the step is halved."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isl_core import Execution, Model, Sampling, Scenario, plan_scenario
from isl_core.kernels.draws import split_ahead
from isl_core.riccati import kalman_bucy
from isl_core.scenario.presets import at_rate
from isl_core.scenario.tuning import TuningGrids, tune

MODEL = Model.from_w(1.0, 3.0, 20.0)


def _split(level: int, base: int, bridges: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """``base`` base steps' (v, ε) split ``level`` times, from seed 5 and the levels' bridge normals."""
    law = Scenario().noise_law()
    if level == 0:
        bridge = np.zeros((base, 1, 2))
    else:
        bridge = np.concatenate([b[:, : 1 << lev] for lev, b in enumerate(bridges[:level])], axis=1)
    vs, eps = np.empty(base << level), np.empty(base << level)
    split_ahead(np.random.default_rng(5), law, np.empty(base), np.empty(base), bridge, 0, base, level, vs, eps)
    return vs, eps


def test_the_steps_of_a_halved_grid_add_up_to_the_coarse_grids_steps():
    """√(h/2)·(ξ_2k + ξ_2k+1) = √h·ξ_k for the signal's and the observation's draws, at every level of refinement."""
    rng = np.random.default_rng(0)
    base = 40
    bridges = [rng.standard_normal((base, 1 << lev, 2)) for lev in range(3)]
    coarse = _split(0, base, bridges)
    assert np.array_equal(coarse[0], np.random.default_rng(5).standard_normal(2 * base)[0::2])  # v_0, ε_0, v_1, …
    for level in (1, 2, 3):
        fine = _split(level, base, bridges)
        prev = _split(level - 1, base, bridges)
        for f, c in zip(fine, prev, strict=True):
            np.testing.assert_allclose(math.sqrt(0.5) * (f[0::2] + f[1::2]), c, rtol=0, atol=1e-13)
    # fine draws are standard normals, independent of each other: their sample moments
    v, e = _split(3, 4000, [rng.standard_normal((4000, 1 << lev, 2)) for lev in range(3)])
    n = v.size
    for x in (v, e):
        assert abs(x.mean()) < 4.0 / math.sqrt(n) and abs(x.var() - 1.0) < 4.0 * math.sqrt(2.0 / n)
        assert abs(np.mean(x[0::2] * x[1::2])) < 4.0 / math.sqrt(n / 2)


def test_the_grid_reads_the_sensor_at_its_rate_and_a_refined_grid_halves_the_step_only():
    sc = at_rate({"c": ("", 20.0, Scenario())}, 10.0)["c"][2]
    assert sc.sensor_interval == pytest.approx(0.1)
    r_min = kalman_bucy(MODEL).r_min
    plans = [plan_scenario(MODEL, MODEL.beta, sc, horizon=4.0, windows=2, refine=r) for r in (0, 1, 2)]
    for r, plan in enumerate(plans):
        assert (plan.q, plan.N) == (plans[0].q << r, plans[0].N << r)
        assert plan.q * plan.h * r_min == pytest.approx(0.1, rel=1e-12)  # one reading: 1/R, whatever the step
    # a slower sensor of its own keeps its interval; no rate, no change
    slow = at_rate({"s": ("", 20.0, Scenario(sensor_interval=0.5))}, 10.0)["s"][2]
    assert slow.sensor_interval == 0.5 and at_rate({"c": ("", 20.0, Scenario())}, None)["c"][2] == Scenario()
    with pytest.raises(ValueError, match=r"refine = 1 needs a sensor interval"):
        plan_scenario(MODEL, MODEL.beta, Scenario(), horizon=4.0, refine=1)
    with pytest.raises(ValueError, match=r"rate \(sensor readings per 1/r_min\)"):
        at_rate({}, -1.0)


GRIDS = TuningGrids(isl_ell=(-3.0, 0.0), memory=(3.0, 30.0), robust_c=(1.345,), imm_switch=(1e-2,), imm_modes=(6,))
PRESETS = {
    "drop": ("σ 200 → 2 at 3/r_min", 200.0, Scenario(sigma_knots=((3.0, 2.0),))),
    "constant": ("constant σ", 20.0, Scenario()),
}


@pytest.mark.parametrize("rate", [10.0, 100.0])
def test_halving_the_step_moves_no_cell_by_more_than_its_half_width(rate):
    """The table's h-convergence at small size: every variant's every cell at q and 2q steps per reading, same seeds,
    same path; the difference within the coarse cell's interval half-width (the tolerance of the table itself)."""
    kw = {
        "presets": PRESETS,
        "sampling": Sampling.first(4, horizon=6.0, burn=2.0),
        "grids": GRIDS,
        "execution": Execution(workers=1, cache=False),
        "rate": rate,
    }
    coarse, fine = tune(1.0, **kw), tune(1.0, refine=1, **kw)
    assert fine.substeps == tuple(2 * q for q in coarse.substeps) and fine.reading_time == pytest.approx(
        coarse.reading_time, rel=1e-12
    )
    r0, lo, hi = coarse.stats()
    r1 = fine.stats()[0]
    assert np.all(np.isfinite(r0)) and np.all(np.isfinite(r1))
    assert np.all(np.abs(r1 - r0) <= (hi - lo) / 2.0)
    assert not np.array_equal(r0, r1)  # the runs did change: the check compared two grids
