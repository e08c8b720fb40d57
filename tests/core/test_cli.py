"""Smoke tests of the core's ``isl`` command line (``python -m isl_core``, small horizons): outputs exist and parse;
bad input → exit 2, one line. The dashboard's commands (``figure3``, ``serve``, the sweep's figures) are the app's
tests."""

from __future__ import annotations

import json
import sys
import tomllib
from pathlib import Path

import pytest

from isl_core.cli import main
from isl_core.paper import A31_NU_OVER_BETA as PAPER_A31

ROOT = Path(__file__).resolve().parents[2]
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _json(capsys) -> object:
    return json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))


def test_the_version_is_spelled_once_and_printed(capsys):
    """One version string, ``isl_core.__version__``: pyproject.toml reads it (no version of its own), the installed
    metadata carries it and ``isl --version`` prints it."""
    import importlib.metadata

    import isl_core

    meta = tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))
    assert "version" not in meta["project"] and meta["project"]["dynamic"] == ["version"]
    assert meta["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "isl_core.__version__"}
    assert importlib.metadata.version("isl") == isl_core.__version__
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"isl {isl_core.__version__}"


def test_run_table_and_json(capsys):
    assert main(["run", "--sigma", "20", "--horizon", "3", "--seed", "2"]) == 0
    out = capsys.readouterr().out
    assert "r_min" in out and "š/s theory" in out and len(out.strip().splitlines()) == 3 + 3 + 2
    assert "averaging window: t in [0, T], no burn-in" in out
    assert main(["run", "--alpha", "0", "--beta", "3", "--sigma", "5", "--m", "2", "--horizon", "3", "--json"]) == 0
    res = _json(capsys)
    assert res["model"] == {"alpha": 0.0, "beta": 3.0, "sigma": 5.0, "m": 2} and res["nu"] == 3.0
    assert len(res["s"]) == len(res["ratio_check"]) == len(res["theory_ratio_check"]) == 2
    stretch = res["window"]["lengthened_by"]
    assert stretch >= 1.0 and res["window"]["requested_horizon_over_r_min"] == 3.0
    assert res["T"] == pytest.approx(3.0 * stretch / res["r_min"]) and res["N"] * res["h"] == pytest.approx(res["T"])
    assert res["ratio_check"][0] == pytest.approx(res["s_check"][0] / res["s"][0])


def test_the_core_command_alone_computes_and_writes_data_without_the_dashboard(tmp_path):
    """``python -m isl_core``: the compute commands, in a process where the dashboard package cannot be imported;
    its sweep writes the CSV and JSON only, and the dashboard's commands say what to install."""
    import subprocess

    code = (
        "import sys; sys.modules['app'] = None; sys.modules['panel'] = None; sys.modules['bokeh'] = None\n"
        "import runpy; runpy.run_module('isl_core', run_name='__main__')"
    )

    def isl_core(*args):
        return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=300)

    out = tmp_path / "fig2"
    done = isl_core(
        "sweep",
        "--alphas",
        "1",
        "--sigmas",
        "20",
        "--ell-min",
        "0",
        "--ell-max",
        "0",
        "--horizon",
        "5",
        "--seeds",
        "0",
        "--batches",
        "2",
        "--quiet",
        "--out",
        str(out),
    )
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in out.iterdir()) == ["fig2.csv", "fig2.json"]
    helped = isl_core("--help")
    assert helped.returncode == 0 and "worstcase" in helped.stdout
    assert "figure3" not in helped.stdout and "serve" not in helped.stdout
    refused = isl_core("figure3")
    assert (refused.returncode, refused.stderr) == (
        2,
        "isl figure3: the dashboard needs the app extra: pip install 'isl[app]'\n",
    )


def test_recommend_table_beside_paper(capsys):
    assert main(["recommend", "--alphas", "1", "5", "--no-verify"]) == 0
    out = capsys.readouterr().out
    assert "paper (A.31)" in out and "predicted (theory) only" in out
    assert main(["recommend", "--alphas", "1", "--horizon", "20", "--seeds", "4", "--batches", "4", "--json"]) == 0
    (row,) = _json(capsys)
    assert row["alpha"] == 1.0 and row["nu"] == pytest.approx(row["beta"] * row["nu_over_beta"])
    assert row["simulated_low"] <= row["simulated_worst"] <= row["simulated_high"]
    (paper,) = row["paper_a31"]
    assert paper["nu_over_beta"] == PAPER_A31[1.0] and paper["simulated"] is not None


def test_recommend_other_model_has_no_paper_column(capsys):
    assert main(["recommend", "--alphas", "1", "--w", "2", "--no-verify", "--json"]) == 0
    (row,) = _json(capsys)
    assert row["paper_a31"] == [] and row["w"] == 2.0


def test_worstcase_table_and_json(capsys):
    """The Fig. 2 worst-case table (all five α, σ ∈ [2, 200]) printed, then a JSON run checked for consistency."""
    argv = [
        "worstcase",
        "--alphas",
        "0.04,0.2,1,5,25",
        "--n-sigma",
        "3",
        "--horizon",
        "30",
        "--seeds",
        "0",
        "--batches",
        "4",
        "--quiet",
    ]
    assert main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    heads = [k for k, line in enumerate(lines) if line.lstrip().startswith("alpha |")]
    assert len(heads) == 2 and "KBF oracle" in lines[heads[0]] and "ISL model-aware" in lines[heads[0]]
    assert "ISL, minimax ν" in lines[heads[0]] and "ISL, ν from table A.31" in lines[heads[0]]  # each tuning's origin
    for head in heads:  # one row per α, one column per filter (simulated table, then theory)
        rows = lines[head + 1 : head + 6]
        assert [float(r.split("|")[0]) for r in rows] == [0.04, 0.2, 1.0, 5.0, 25.0]
        assert all(len(r.split("|")) == 1 + 7 for r in rows)
    assert any(
        line.startswith("averaging window of each simulated run: a burn-in of 10/r_min, then 30/r_min")
        for line in lines
    )
    assert (
        main(
            [
                "worstcase",
                "--alphas",
                "1",
                "5",
                "--filters",
                "kbf,kbf_adaptive,isl",
                "--n-sigma",
                "2",
                "--horizon",
                "20",
                "--seeds",
                "0,1",
                "--batches",
                "2",
                "--json",
            ]
        )
        == 0
    )
    res = _json(capsys)
    assert res["meta"]["filters"] == ["kbf", "kbf_adaptive", "isl"] and res["meta"]["seeds"] == [0, 1]
    assert res["meta"]["burn_in_over_r_min"] == 10.0 and len(res["meta"]["lengthened_by"]) == 2
    assert len(res["rows"]) == 2 * 3
    for row in res["rows"]:
        assert row["worst_low"] <= row["worst"] <= row["worst_high"] and row["worst_sigma"] in res["meta"]["sigmas"]
        assert (row["theory_worst"] is None) == (row["filter"] == "kbf_adaptive")
        assert (row["nu"] is None) == (row["filter"] != "isl")
        if row["filter"] == "kbf":
            assert row["theory_worst"] == pytest.approx(1.0)


@pytest.mark.parametrize(
    "argv",
    [
        [],
        ["bogus"],
        ["run", "--sigma", "-1"],
        ["run", "--sigma", "nan"],
        ["run", "--m", "9"],
        ["run", "--alpha", "0"],
        ["run", "--seed", "-1"],
        ["run", "--nu", "abc"],
        ["run", "--horizon", "1e12"],
        ["sweep", "--ell-min", "3", "--ell-max", "1"],
        ["sweep", "--batches", "0", "--alphas", "1", "--horizon", "5"],
        ["recommend", "--alphas", "x"],
        ["recommend", "--m", "0", "--no-verify"],
        ["worstcase", "--sigma-min", "5", "--sigma-max", "2"],
        ["worstcase", "--filters", "kbf,nope"],
        ["worstcase", "--alphas", "1,x"],
        ["worstcase", "--n-sigma", "1"],
        ["worstcase", "--alphas", "0"],
        ["sweep", "--alphas", "0", "--horizon", "5"],
    ],
)
def test_bad_arguments_exit_2_with_one_line(argv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a rejected command writes nothing
    assert main(argv) == 2
    assert list(tmp_path.iterdir()) == []
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("isl") and "Traceback" not in captured.err
    assert captured.out == ""


def test_help_exits_0(capsys):
    assert main(["--help"]) == 0
    assert "recommend" in capsys.readouterr().out
