"""One tuning rule for every family (isl_core.scenario.tuning): the minimax of the period statistic, on common noise,
cached."""

from __future__ import annotations

import numpy as np
import pytest

from isl_core import Execution, Model, Sampling, Scenario, average_scenario
from isl_core.riccati import kalman_bucy
from isl_core.scenario.periods import edge_times, per_seed
from isl_core.scenario.tuning import _MEMORY_CACHE, FAMILIES, TuningGrids, tune, variant_name

PRESETS = {
    "drop": ("σ 20 → 2 at 2/r_min", 20.0, Scenario(sigma_knots=((2.0, 2.0),))),
    "constant": ("constant σ", 20.0, Scenario()),
}
GRIDS = TuningGrids(
    isl_ell=(-4.0, -2.0, 0.0),
    memory=(10.0, 100.0, 1000.0),
    robust_c=(1.345, 3.0),
    imm_switch=(1e-3, 1e-1),
    imm_modes=(5,),
)
KW = {"presets": PRESETS, "sampling": Sampling.first(6, horizon=5.0, burn=2.0), "grids": GRIDS}
NO_CACHE = Execution(cache=False)


@pytest.fixture(scope="module")
def tuning():
    return tune(1.0, execution=NO_CACHE, **KW)


def test_every_variant_of_every_family_rides_in_the_runs_with_its_knob(tuning):
    assert tuning.names[:3] == ("clairvoyant", "kbf", "isl") and tuning.family[:3] == (
        "clairvoyant",
        "kbf",
        "isl_paper",
    )
    for family in FAMILIES:
        idx = tuning.variants(family)
        assert [tuning.knobs[j] for j in idx] == GRIDS.points(family)
        assert [tuning.names[j] for j in idx] == [variant_name(family, k) for k in GRIDS.points(family)]
    assert [(tuning.presets[p], per.name) for p, per in tuning.cells] == [
        ("drop", "after_1"),
        ("drop", "after_2"),
        ("drop", "settled"),
        ("constant", "settled"),
    ]
    assert tuning.y.shape == (6, 4, len(tuning.names), 3)  # seeds × cells × filters × coordinates
    # one reading lasts 1/R at the default rate R = 100 readings per 1/r_min, q steps of h: W readings are W/R
    r_min = kalman_bucy(Model.from_w(1.0, 3.0, 20.0, 3)).r_min
    assert tuning.rate == 100.0 and tuning.reading_time[1] == pytest.approx(0.01, rel=1e-12)
    assert tuning.reading_time[1] == pytest.approx(tuning.substeps[1] * tuning.h[1] * r_min, rel=1e-12)


def test_the_minimax_and_the_oracle_knobs_are_the_least_largest_ratios_written_out(tuning):
    ratio = np.sqrt(tuning.y.mean(axis=0)).max(axis=2)  # (cells, filters): each cell at its worst coordinate
    drop = [0, 1, 2]
    for family in FAMILIES:
        idx = tuning.variants(family)
        worst = ratio[:, idx].max(axis=0)
        assert tuning.minimax(family) == idx[int(np.argmin(worst))]
        assert tuning.oracle(family, 0) == idx[int(np.argmin(ratio[np.ix_(drop, idx)].max(axis=0)))]
        assert tuning.oracle(family, 1) == idx[int(np.argmin(ratio[3, idx]))]


def test_a_minimax_knob_at_its_grids_end_is_named(tuning):
    """No bracketed optimum: a knob whose minimax value is its grid's first or last is named, one with a single
    value never (the IMM's modes here)."""
    for family in FAMILIES:
        knob, edges = tuning.knobs[tuning.minimax(family)], tuning.on_edge(family)
        for name, value in knob.items():
            values = sorted({p[name] for p in GRIDS.points(family)})
            if value == values[0] and len(values) > 1:
                assert edges[name].startswith("lowest")
            elif value == values[-1] and len(values) > 1:
                assert edges[name] == "highest"
            else:
                assert name not in edges
    assert "modes" not in tuning.on_edge("imm")


def test_a_tuned_filter_run_alone_on_the_same_grid_gives_its_column_of_the_tuning(tuning):
    """Common random numbers: every filter's error depends on the noise and the grid only, not on the filters
    beside it — the tuned IMM and VB filters run alone (on the grid of all the variants) give their columns."""
    sigma0, scenario = tuning.scenarios[0]  # the drop as the tuning ran it: read at its rate
    model = Model.from_w(1.0, 3.0, sigma0, 3)
    every = tuning.grid_filters(model)
    chosen = [tuning.minimax("imm"), tuning.minimax("vb")]
    periods = tuple(per for _, per in tuning.cells[:3])
    avg = average_scenario(
        model,
        model.beta * 0.2,
        scenario,
        seeds=range(6),
        horizon=5.0,
        edges=edge_times(periods, 5.0),
        extra=[tuning.filter(j, model) for j in chosen],
        grid_filters=every,
    )
    assert tuning.steps[0] == avg.run.N
    y = per_seed(avg.mse, avg.run, periods)
    np.testing.assert_allclose(y[:, :, 3:], tuning.y[:, :3, chosen], rtol=1e-12)


def test_a_tuning_is_cached_on_disk_and_read_back_bit_for_bit(tmp_path, monkeypatch, tuning):
    monkeypatch.setenv("ISL_CACHE_DIR", str(tmp_path))
    _MEMORY_CACHE.clear()
    first = tune(1.0, **KW)
    assert "computed now" in first.origin and str(tmp_path) in first.origin
    np.testing.assert_array_equal(first.y, tuning.y)  # the same inputs, the same numbers: reproducible
    assert tune(1.0, **KW) is first  # this process: from memory
    _MEMORY_CACHE.clear()
    again = tune(1.0, **KW)
    assert "read from the cache" in again.origin and again is not first
    np.testing.assert_array_equal(again.y, first.y)
    more = Sampling.first(7, horizon=5.0, burn=2.0)
    assert tune(1.0, compute=False, **{**KW, "sampling": more}) is None  # not cached: not computed either
    shifted = Sampling(seeds=tuple(range(1, 7)), horizon=5.0, burn=2.0)  # as many seeds, other ones
    assert tune(1.0, compute=False, **{**KW, "sampling": shifted}) is None  # the seeds themselves are keyed


def test_an_unwritable_cache_keeps_the_tuning_in_memory(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    monkeypatch.setenv("ISL_CACHE_DIR", str(blocker / "isl"))
    _MEMORY_CACHE.clear()
    small = {**KW, "presets": {"constant": PRESETS["constant"]}, "sampling": Sampling.first(2, horizon=5.0, burn=2.0)}
    res = tune(1.0, **small)
    assert "kept in memory" in res.origin and tune(1.0, **small) is res


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"sampling": Sampling(seeds=(0,), batches=2)}, "sampling.seeds"),
        ({"sampling": 32}, "sampling"),
        ({"execution": Execution(executor=object())}, "execution.executor"),
        ({"execution": "fast"}, "execution"),
        ({"refine": -1}, "refine"),
        ({"alpha": 0.0}, "alpha"),
        ({"presets": {}}, "presets"),
    ],
)
def test_bad_settings_are_named(kwargs, named):
    with pytest.raises(ValueError, match=named):
        tune(**{"alpha": 1.0, **kwargs})


def test_any_seeds_of_a_sampling_give_those_seeds_runs(tuning):
    """Seeds as a sequence: a tuning on seeds (4, 1) holds, seed by seed, the rows of those seeds in the tuning on
    0 … 5 (each run depends on its seed only)."""
    picked = tune(1.0, execution=NO_CACHE, **{**KW, "sampling": Sampling(seeds=(4, 1), horizon=5.0, burn=2.0)})
    assert picked.seeds == (4, 1)
    np.testing.assert_array_equal(picked.y, tuning.y[[4, 1]])
