"""The fair table (isl_core.scenario.table), the who-wins maps (isl_core.scenario.map) and ``isl scenario``."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from isl_core import Execution, Sampling, Scenario, scenario_table
from isl_core.cli import main
from isl_core.scenario.heldout import held_out
from isl_core.scenario.map import who_wins_map
from isl_core.scenario.table import PRESETS, table_from
from isl_core.scenario.tuning import _MEMORY_CACHE, FAMILIES, TuningGrids, tune

SMALL = {
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
NO_CACHE = Execution(cache=False)


@pytest.fixture(scope="module")
def tuning():
    return tune(1.0, presets=SMALL, sampling=Sampling.first(8, horizon=5.0, burn=2.0), grids=GRIDS, execution=NO_CACHE)


@pytest.fixture(scope="module")
def table(tuning):
    return table_from(tuning)


@pytest.fixture(autouse=True)
def _own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ISL_CACHE_DIR", str(tmp_path))


def test_each_tuned_row_sits_at_its_tuning_curves_minimax_point(tuning, table):
    """A tuned row is its variant's column of the tuning run: its largest ratio over the cells is the least over the
    knob's grid, and its stated tuning is that variant's knob."""
    ratio = np.sqrt(tuning.y.mean(axis=0)).max(axis=2)  # (cells, filters), worst coordinate: the curves, written out
    for family in FAMILIES:
        row = next(i for i, r in enumerate(table.rows) if r.name == family)
        idx = tuning.variants(family)
        curve = ratio[:, idx].max(axis=0)
        assert table.stats.ratio[row].max() == pytest.approx(curve.min(), rel=1e-12)
        assert table.rows[row].tuning == tuning.knobs[idx[int(np.argmin(curve))]]
        np.testing.assert_allclose(table.stats.ratio[row], ratio[:, idx[int(np.argmin(curve))]], rtol=1e-12)


def test_every_row_states_its_tuning_and_origin_and_the_oracle_is_no_worse(tuning, table):
    roles = [r.role for r in table.rows]
    assert roles[:2] == ["reference", "reference"] and roles.count("tuned") == len(FAMILIES)
    assert roles.count("oracle") == len(FAMILIES) and roles.count("paper") == 1  # α = 1 is in table (A.31)
    assert all(r.origin for r in table.rows)
    assert all("minimax over 2 presets" in r.origin for r in table.rows if r.role == "tuned")
    assert all(len(r.tuning) == 2 for r in table.rows if r.role == "oracle")  # a knob per preset
    for family in FAMILIES:
        tuned = next(i for i, r in enumerate(table.rows) if r.name == family)
        oracle = next(i for i, r in enumerate(table.rows) if r.name == f"oracle:{family}")
        for p in range(2):
            assert table.preset(p)[0][oracle] <= table.preset(p)[0][tuned] + 1e-12


def test_the_winner_of_each_cell_is_the_lowest_contender_with_a_paired_margin(table):
    contenders = [i for i, r in enumerate(table.rows) if r.role in ("tuned", "paper")]
    for c in range(table.stats.ratio.shape[1]):
        order = sorted(contenders, key=lambda i: table.stats.ratio[i, c])
        assert (table.winner[c], table.runner_up[c]) == (order[0], order[1])
        ratio = table.stats.ratio
        assert table.margin[c] == pytest.approx(ratio[order[1], c] / ratio[order[0], c], rel=1e-12)
        assert table.margin_low[c] <= table.margin[c] and table.tie[c] == (table.margin_low[c] <= 1.0)


def test_the_clairvoyant_row_reads_one_within_its_sampling_error(tuning, table):
    y = tuning.y[:, :, 0]
    se = y.std(axis=0, ddof=1) / math.sqrt(y.shape[0])
    assert np.all(np.abs(y.mean(axis=0) - 1.0) <= 4.5 * se)
    assert np.all(table.stats.low[0] <= table.stats.ratio[0]) and np.all(table.stats.ratio[0] <= table.stats.high[0])


def test_the_command_prints_the_table_as_json_and_csv_and_refuses_unknown_scenarios(tmp_path, capsys):
    out = tmp_path / "table.csv"
    args = ["scenario", "--scenarios", "sensor,constant", "--n-seeds", "2", "--horizon", "6", "--no-cost"]
    assert main([*args, "--json", "--csv", str(out)]) == 0
    doc = json.loads(capsys.readouterr().out)
    meta, rows = doc["meta"], doc["rows"]
    assert list(meta["scenarios"]) == ["sensor", "constant"] and meta["tuning_seeds"] == [0, 1]
    assert meta["report_seeds"] == [2, 9] and meta["seeds_disjoint"]  # held out: four times as many, after them
    assert all(r["seeds"] == ([0, 1] if r["role"] == "oracle" else [2, 9]) for r in rows)
    cell = rows[0]["cells"]["sensor:settled"]
    assert len(cell["coordinates"]) == 3 and cell["ratio"] == max(cell["coordinates"])
    assert cell["coordinates"][cell["coordinate"] - 1] == cell["ratio"] and cell["seeds_diverged"] == 0
    assert [c["cell"] for c in meta["cells"]] == ["sensor:settled", "constant:settled"]
    assert [r["name"] for r in rows][:3] == ["clairvoyant", "kbf", "isl"]
    assert all(r["origin"] and "tuning" in r for r in rows)
    assert {w["cell"] for w in doc["winners"]} == {"sensor:settled", "constant:settled"}
    beyond = doc["beyond"]  # the presets beyond every assumed σ range, on the report seeds, each row's range said
    assert set(beyond["scenarios"]) == {"sigma_2000", "sigma_drop_far"} and beyond["seeds"] == [2, 9]
    assert "[2, 200]" in beyond["rows"]["kbf_adaptive"]["assumes"] and "oracle:vb" not in beyond["rows"]
    assert set(meta["clairvoyant_reads_1_within_its_interval"]) == {"sensor:settled", "constant:settled"}
    assert meta["one_reading_over_r_min"]["sensor"] == pytest.approx(0.1, rel=0.1)
    assert meta["shipped_tuning"]["label"] == "tuned at α = 1, m = 3"  # what the dashboard uses without a tuning
    with open(out) as fh:
        lines = list(csv.DictReader(fh))
    assert len(lines) == 2 * len(rows) and lines[0]["filter"] == "clairvoyant"
    assert float(lines[2]["ratio"]) == pytest.approx(rows[1]["cells"]["sensor:settled"]["ratio"])
    _MEMORY_CACHE.clear()
    assert main([*args, "--quiet"]) == 0  # the same tuning, now from the disk cache: the text table
    text = capsys.readouterr().out
    assert "read from the cache" in text and "who wins each cell" in text and "out of sample" in text
    assert main(["scenario", "--scenarios", "sigma_dorp", "--quiet"]) == 2
    assert "unknown scenario 'sigma_dorp'" in capsys.readouterr().err


def test_the_command_prints_the_tuning_curves(tmp_path, capsys):
    out = tmp_path / "curves.csv"
    args = ["scenario", "--scenarios", "constant", "--n-seeds", "2", "--horizon", "6", "--tune"]
    assert main([*args, "--json", "--csv", str(out)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert set(doc["tuned"]) == set(FAMILIES)
    vb = [c for c in doc["curves"] if c["family"] == "vb"]
    assert next(c["memory"] for c in vb) == 1.1 and vb[-1]["memory"] == 3000.0 and sum(c["minimax"] for c in vb) == 1
    assert all(
        c["memory_over_r_min"] == pytest.approx(c["memory"] * doc["meta"]["one_reading_over_r_min"]["constant"])
        for c in vb
    )
    with open(out) as fh:
        assert len(list(csv.DictReader(fh))) == len(doc["curves"])
    assert main([*args, "--quiet"]) == 0
    assert "tuning curves" in capsys.readouterr().out


def test_the_sigma_step_map_has_a_row_per_period_after_the_step_with_the_tables_tuning(tuning):
    res = who_wins_map("sigma_step", values=(0.1, 10.0), n_seeds=6, after=4.0, tuning=tuning)
    assert res.ratio.shape == (4, 2, len(res.filters)) and np.allclose(res.rows, [0.0, 1.0, 2.0, 3.0])
    assert res.filters == ("clairvoyant", "kbf", "isl", "isl_model", "kbf_adaptive", "vb", "kbf_robust", "imm")
    assert res.origin.startswith("tuned") and np.all(res.winner >= 1) and np.all(res.margin >= 1.0)
    first = max(tuning.seeds) + 1  # held out: the six seeds after the tuning's
    assert res.seeds == tuple(range(first, first + 6)) and f"seeds from {first} on" in res.origin
    # after σ drops tenfold the filter for σ(0) stays off (its gain is too small: 2.0 measured), the learners recover
    pooled = np.sqrt((res.ratio[:, 0] ** 2).mean(axis=0))  # over the 4/r_min after the step
    assert pooled[1] > 1.5 and pooled[4:].min() < pooled[1] / 1.3
    np.testing.assert_array_equal(res.tie, res.margin_low <= 1.0)


def test_the_one_dimensional_maps_and_the_command(capsys):
    res = who_wins_map("tails", values=(3.0, 100.0), n_seeds=2, after=6.0, untuned=True)
    assert res.ratio.shape == (1, 2, len(res.filters)) and np.isnan(res.rows[0]) and res.origin.startswith("untuned")
    assert (
        main(
            [
                "scenario",
                "--map",
                "sensor",
                "--values",
                "0,0.1",
                "--n-seeds",
                "2",
                "--horizon",
                "6",
                "--json",
                "--untuned",
            ]
        )
        == 0
    )
    doc = json.loads(capsys.readouterr().out)
    assert doc["meta"]["map"] == "sensor" and [c["value"] for c in doc["cells"]] == [0.0, 0.1]
    assert doc["meta"]["seeds"] == [0, 1]  # untuned: seeds 0 … --n-seeds − 1
    assert all(c["winner"] in doc["meta"]["filters"] and c["winner"] != "clairvoyant" for c in doc["cells"])
    assert main(["scenario", "--map", "sigma_step", "--horizon", "10", "--quiet"]) == 2
    assert "--horizon must be at least 10" in capsys.readouterr().err
    with pytest.raises(ValueError, match="kind"):
        who_wins_map("drift")


def test_the_presets_are_the_issues_scenarios():
    assert list(PRESETS) == ["sigma_drop", "sigma_rise", "student3", "outliers", "sensor", "constant"]


def test_scenario_table_is_the_tuning_read_on_held_out_seeds():
    """``scenario_table`` = ``table_from`` of ``tune`` with its arguments, read on the report seeds after the
    tuning's (four times as many by default); a bad level is refused by name."""
    few, one_thread = Sampling.first(2, horizon=3.0, burn=2.0, level=0.9), Execution(workers=1)
    args = dict(m=3, w=3.0, grids=GRIDS, execution=one_thread)
    got = scenario_table(1.0, scenarios={"drop": SMALL["drop"]}, sampling=few, **args)
    res = tune(1.0, presets={"drop": SMALL["drop"]}, sampling=few, **args)  # from the cache the call above filled
    want = table_from(res, 0.9, held_out(res, None, execution=one_thread))
    for name in ("ratio", "low", "high", "coordinates", "worst_seed", "worst_seed_id"):
        np.testing.assert_array_equal(getattr(got.stats, name), getattr(want.stats, name))
    assert [r.name for r in got.rows] == [r.name for r in want.rows] and got.level == 0.9
    tuned = next(i for i, r in enumerate(got.rows) if r.role == "tuned")
    assert got.seeds[tuned] == tuple(range(2, 2 + 4 * 2))
    with pytest.raises(ValueError, match=r"^sampling\.level must"):
        scenario_table(1.0, scenarios={"drop": SMALL["drop"]}, sampling=Sampling.first(2, level=0.3), **args)
