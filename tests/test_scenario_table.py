"""The who-wins table of scenarios (isl_core.scenario_table)."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from isl_core.cli import main
from isl_core.scenario_table import PRESETS, scenario_table


@pytest.fixture(scope="module")
def table():
    chosen = {k: PRESETS[k] for k in ("sigma_drop", "constant")}
    return scenario_table(1.0, scenarios=chosen, seeds=6, horizon=16.0)


def test_rows_columns_and_intervals(table):
    assert table.scenarios == ("sigma_drop", "constant")
    assert table.filters[:3] == ("clairvoyant", "kbf", "isl")
    assert {"kbf_adaptive", "vb", "kbf_robust", "isl_minimax", "isl_model"} <= set(table.filters)
    assert "(A.31)" in table.labels[2]  # α = 1 is in paper A's table: its ν is the first ISL row
    assert table.worst.shape == table.low.shape == table.high.shape == (len(table.filters), 2)
    assert np.all(table.low < table.high)
    assert "clairvoyant" not in table.winner and np.all(table.margin >= 1.0)


def test_a_winner_is_named_only_where_the_seeds_tell_it_from_the_runner_up(table):
    drop, constant = 0, 1
    np.testing.assert_array_equal(table.tie, table.margin_low <= 1.0)
    assert np.all(table.margin_low <= table.margin + 1e-12)
    assert all(w != r for w, r in zip(table.winner, table.runner_up, strict=True))
    # constant σ and Gaussian noise: the σ(0)-optimal, adaptive and variational-Bayes filters are the same filter up
    # to the noise, so whichever comes first, the seeds cannot tell it from the next: a tie, not a winner
    assert table.tie[constant]
    # after σ drops 100-fold, the model-aware ISL filter is far below the filters that learn or assume σ
    assert table.winner[drop].startswith("isl")


def test_the_figures_say_what_the_scenarios_do(table):
    drop, constant = 0, 1
    # constant σ: the clairvoyant filter is the Kalman–Bucy filter (on the grid vs in continuous time: within 3 %)
    c, k = table.worst[0, constant], table.worst[1, constant]
    assert k == pytest.approx(c, rel=0.03)
    # σ 200 → 2: the filter designed for σ = 200 is far off afterwards; the ISL filter, which needs no σ, is not
    isl = table.worst[2, drop]
    assert table.worst[1, drop] > 4.0 * table.worst[0, drop]
    assert isl < 0.5 * table.worst[1, drop]


@pytest.mark.parametrize(("kwargs", "named"), [({"seeds": 1}, "seeds"), ({"window": 0.0}, "window"),
                                               ({"burn": 30.0}, "burn"), ({"level": 1.0}, "level")])
def test_bad_settings_are_named(kwargs, named):
    with pytest.raises(ValueError, match=named):
        scenario_table(1.0, **kwargs)


def test_the_command_prints_json_and_writes_csv_and_refuses_unknown_scenarios(tmp_path, capsys):
    out = tmp_path / "table.csv"
    assert main(["scenario", "--seeds", "2", "--horizon", "12", "--scenarios", "sensor,constant", "--json",
                 "--csv", str(out)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert list(doc["meta"]["scenarios"]) == ["sensor", "constant"] and doc["meta"]["seeds"] == 2
    meta = doc["meta"]
    assert set(meta["tie"]) == set(meta["margin_low95"]) == set(meta["runner_up"]) == {"sensor", "constant"}
    assert all(meta["tie"][s] == (meta["margin_low95"][s] <= 1.0) for s in meta["tie"])
    assert [r["filter"] for r in doc["rows"]][:3] == ["clairvoyant", "kbf", "isl"]
    with open(out) as fh:
        rows = list(csv.DictReader(fh))
    assert [r["filter"] for r in rows] == [r["filter"] for r in doc["rows"]]
    assert float(rows[1]["constant"]) == pytest.approx(doc["rows"][1]["constant"])
    assert main(["scenario", "--scenarios", "sigma_dorp", "--quiet"]) == 2
    assert "unknown scenario 'sigma_dorp'" in capsys.readouterr().err


def test_the_sigma_step_map_has_a_row_per_window_after_the_step_and_names_a_winner_per_cell():
    from isl_core.scenario_map import who_wins_map

    res = who_wins_map("sigma_step", values=(0.1, 10.0), seeds=3, after=4.0)
    assert res.ratio.shape == (4, 2, len(res.filters)) and np.allclose(res.rows, [0.0, 1.0, 2.0, 3.0])
    assert np.all(res.winner >= 1) and np.all(res.margin >= 1.0)
    # right after σ drops tenfold the filter tuned for σ(0) is the worst of all (its gain is ten times too small)
    assert np.argmax(res.ratio[0, 0, 1:]) == 0


def test_the_one_dimensional_maps_and_the_command(capsys):
    from isl_core.scenario_map import who_wins_map

    res = who_wins_map("tails", values=(3.0, 100.0), seeds=2, after=6.0)
    assert res.ratio.shape == (1, 2, len(res.filters)) and np.isnan(res.rows[0])
    assert main(["scenario", "--map", "sensor", "--values", "0,0.1", "--seeds", "2", "--horizon", "6", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["meta"]["map"] == "sensor" and [c["value"] for c in doc["cells"]] == [0.0, 0.1]
    assert all(c["winner"] in doc["meta"]["filters"] and c["winner"] != "clairvoyant" for c in doc["cells"])
    assert main(["scenario", "--map", "sigma_step", "--horizon", "10", "--quiet"]) == 2
    assert "--horizon must be at least 10" in capsys.readouterr().err
    with pytest.raises(ValueError, match="kind"):
        who_wins_map("drift")
