"""The tunings shipped with the package (isl_core.scenario.shipped): made by today's tuning rule, reproducible bit for
bit, read at the nearest grid point and labelled as such, and why a grid in α and m covers every β."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from isl_core import Execution, Model, Sampling, TuningGrids, tune
from isl_core.scenario import PRESETS, shipped
from isl_core.scenario.map import map_filters
from isl_core.scenario.shipped import COMMAND, equivalent_alpha, shipped_json, shipped_tuning, why_not_shipped
from isl_core.scenario.tuning import FAMILIES
from isl_core.scenario.variants import family_filter

REGENERATE = f"the core's tuning rule no longer gives the shipped tunings: regenerate them with `{COMMAND}`"


@pytest.fixture(scope="module")
def grid():
    found = shipped.load_shipped()
    assert found is not None, f"no shipped tunings at {shipped.SHIPPED}: `{COMMAND}` makes them"
    return found


def test_the_shipped_tunings_were_made_by_todays_rule(grid):
    assert shipped.stale(grid) is None, shipped.stale(grid)


def test_the_probe_recomputes_bit_for_bit(grid):
    """The probe is one small tuning under the rule (every preset and family, two seeds): its cells' digest and knobs
    as computed now must be those the file was made with — a change to what a tuning computes fails here."""
    assert shipped.probe_record(shipped.probe_tuning(workers=1)) == grid.probe, REGENERATE


def test_every_shipped_knob_is_on_the_rules_grid_with_its_figure_inside_its_interval(grid):
    grids = TuningGrids(**{k: tuple(v) for k, v in grid.rule["grids"].items()})
    assert grid.entries and {(e["alpha"], e["m"]) for e in grid.entries} >= {(0.5, 3)}  # the default page's model
    for entry in grid.entries:
        assert entry["w"] == shipped.W_GRID
        for family in FAMILIES:
            ratio, low, high, cell = entry["figures"][family]
            assert entry["knobs"][family] in grids.points(family), (entry["alpha"], entry["m"], family)
            assert low <= ratio <= high and cell.split(":")[0] in PRESETS


@pytest.fixture
def small_file(tmp_path):
    """A shipped file under today's rule with two points at m = 2 (α = 0.2 and 1), knobs from the grids."""
    grids = TuningGrids()
    knobs = {f: grids.points(f)[0] for f in FAMILIES}
    figures = {f: [1.1, 1.0, 1.2, "sigma_drop:first1"] for f in FAMILIES}
    entries = [{"alpha": a, "m": 2, "w": 3.0, "knobs": knobs, "figures": figures, "seconds": 1.0} for a in (0.2, 1.0)]
    path = tmp_path / "tunings.json"
    path.write_text(json.dumps({"rule": shipped.rule(), "probe": {}, "entries": entries}), encoding="utf-8")
    return path


def test_between_grid_points_the_nearest_in_log_alpha_is_taken_and_labelled(small_file):
    near = shipped_tuning(0.4, 2, path=str(small_file))  # |log 2| < |log 2.5|: 0.2
    assert near is not None and (near.alpha, near.m, near.exact) == (0.2, 2, False)
    assert near.label == "tuned at α = 0.2, m = 2; your α = 0.4: nearest grid point"
    assert "Tune computes your model's own" in near.origin and "α ∈ {0.2, 1}" in near.origin
    assert shipped_tuning(0.5, 2, path=str(small_file)).alpha == 1.0  # |log 2.5| > |log 2|
    exact = shipped_tuning(1.0, 2, path=str(small_file))
    assert exact.exact and exact.label == "tuned at α = 1, m = 2"
    rounded = shipped_tuning(
        17.0, 2, 3.0 * math.sqrt(34.0) / math.sqrt(34.0), path=str(small_file)
    )  # w = 3 to rounding
    assert rounded.label == "tuned at α = 1, m = 2; your α = 17: nearest grid point"
    model = Model.from_w(0.4, 3.0, 20.0, 2)  # its filters: the knobs on the page's model
    specs = near.tuned_filters(model)
    assert [s.name for s in specs] == list(FAMILIES)
    assert specs[2].label == family_filter("kbf_adaptive", model, near.knobs[2]).label


def test_a_model_given_by_beta_maps_onto_the_grid_by_its_equivalent_alpha(small_file):
    w = 3.0 * 0.2**-1.5  # α = 1 with this w is α = 0.2 at w = 3 (m = 2)
    assert equivalent_alpha(1.0, 2, w) == pytest.approx(0.2, rel=1e-12)
    found = shipped_tuning(1.0, 2, w, path=str(small_file))
    assert (
        found.alpha == 0.2
        and found.exact
        and found.label == f"tuned at α = 0.2, m = 2; your α = 1 with w = {w:g} is α = 0.2 at w = 3"
    )


def test_the_json_of_isl_scenario_names_the_shipped_tuning_and_its_point(small_file):
    said = shipped_json(0.4, 2, path=str(small_file))
    assert said["label"] == "tuned at α = 0.2, m = 2; your α = 0.4: nearest grid point" and not said["exact"]
    assert said["grid_point"] == {"alpha": 0.2, "m": 2, "w": 3.0} and set(said["knobs"]) == set(FAMILIES)
    assert said["figures"]["vb"] == {"ratio": 1.1, "low95": 1.0, "high95": 1.2, "cell": "sigma_drop:first1"}
    assert shipped_json(0.4, 5, path=str(small_file)) == {
        "label": None,
        "why_none": why_not_shipped(0.4, 5, path=str(small_file)),
    }
    json.dumps(said, allow_nan=False)


def test_a_map_without_a_computed_tuning_takes_the_shipped_one(grid, monkeypatch, tmp_path):
    monkeypatch.setenv("ISL_CACHE_DIR", str(tmp_path))  # nothing computed: the shipped tuning nearest α = 0.7
    model = Model.from_w(0.7, 3.0, 20.0, 3)
    nu, label, extra, origin, first = map_filters(model, 0.7, 3, 3.0, None)
    near = shipped_tuning(0.7, 3)
    assert origin.startswith(f"tuned: {near.origin}") and first == len(near.seeds)
    assert nu == model.beta * 2.0 ** near.knobs[0]["ell"] and label == near.tuned_filters(model)[0].label
    assert [e.name for e in extra] == list(FAMILIES)[1:]


def test_no_shipped_tuning_is_said_why(small_file, tmp_path):
    path = str(small_file)
    assert shipped_tuning(0.5, 3, path=path) is None and "no point with m = 3 (m ∈ {2})" in why_not_shipped(
        0.5, 3, path=path
    )
    assert shipped_tuning(0.0, 2, path=path) is None and "α = 0" in why_not_shipped(0.0, 2, path=path)
    data = json.loads(small_file.read_text(encoding="utf-8"))
    data["rule"]["tune"]["seeds"] += 1  # made by another rule: refused, never used silently
    stale = tmp_path / "stale.json"
    stale.write_text(json.dumps(data), encoding="utf-8")
    assert shipped_tuning(0.2, 2, path=str(stale)) is None
    assert "differs in: tune" in why_not_shipped(0.2, 2, path=str(stale)) and COMMAND in why_not_shipped(
        0.2, 2, path=str(stale)
    )
    with pytest.raises(ValueError, match="alpha must be"):
        shipped_tuning(-1.0, 2, path=path)


def test_a_tuning_depends_on_alpha_and_w_only_through_the_equivalent_alpha():
    """Time rescaled by c = 2 (module docstring of isl_core.scenario.shipped): the model at (α/2, w·2^(1/2 − m)) has
    the same statistic in every cell as (α, w) — the same arithmetic up to rounding — so every knob's verdict too."""
    grids = TuningGrids(isl_ell=(-2.0, 0.0), memory=(10.0, 100.0), robust_c=(2.0,), imm_switch=(1e-3,), imm_modes=(6,))
    sampling, execution = Sampling.first(2, horizon=12.0, burn=2.0), Execution(workers=1, cache=False)
    kw = dict(m=2, sampling=sampling, grids=grids, execution=execution)
    presets = {k: PRESETS[k] for k in ("sigma_drop", "sensor")}
    a = tune(1.0, w=3.0, presets=presets, **kw)
    b = tune(0.5, w=3.0 * 2.0**-1.5, presets=presets, **kw)
    assert equivalent_alpha(b.alpha, b.m, b.w) == pytest.approx(a.alpha, rel=1e-12)
    keep = [j for j in range(len(a.names)) if a.family[j] != "isl_paper"]  # table (A.31)'s ν is read at w = 3 only
    np.testing.assert_allclose(b.stats()[0][keep], a.stats()[0][keep], rtol=1e-10)
    assert [b.knobs[b.minimax(f)] for f in FAMILIES] == [a.knobs[a.minimax(f)] for f in FAMILIES]
