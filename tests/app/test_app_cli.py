"""Smoke tests of the dashboard's ``isl`` console script (``app.cli``: the core's command line with ``figure3``,
``serve`` and the sweep's HTML and PNG figures); the core's commands alone are tested in ``tests/core/test_cli.py``."""

from __future__ import annotations

import csv
import json
import sys
import tomllib
import types
from pathlib import Path

import pytest

from app.cli import main

ROOT = Path(__file__).resolve().parents[2]
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _json(capsys) -> object:
    return json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))


@pytest.mark.parametrize("argv", [["figure3", "--sigmas"]])
def test_bad_dashboard_arguments_exit_2_with_one_line(argv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a rejected command writes nothing
    assert main(argv) == 2
    assert list(tmp_path.iterdir()) == []
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("isl") and "Traceback" not in captured.err
    assert captured.out == ""


def test_console_script_is_declared():
    """``isl`` is the core's; it takes the dashboard's commands through the ``isl.cli`` entry point."""
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))
    assert meta["project"]["scripts"]["isl"] == "isl_core.cli:console"
    assert meta["project"]["entry-points"]["isl.cli"] == {"app": "app.cli:extension"}


def test_the_installed_isl_has_the_dashboards_commands():
    """Installed with the app extra, the core's console script loads :data:`app.cli.DASHBOARD`."""
    from app.cli import DASHBOARD
    from isl_core.cli import installed_extension

    assert installed_extension() is DASHBOARD


def test_sweep_writes_csv_json_html_png(tmp_path, capsys):
    out = tmp_path / "fig2"
    argv = [
        "sweep",
        "--alphas",
        "1",
        "--sigmas",
        "2",
        "20",
        "--ell-min",
        "-2",
        "--ell-max",
        "0",
        "--horizon",
        "20",
        "--seeds",
        "1",
        "--batches",
        "4",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert "wrote" in captured.out and "100%" in captured.err  # the progress bar went to stderr
    with open(out / "fig2.csv", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 1 * 2 * 3 * 3
    assert {float(r["nu_over_beta"]) for r in rows} == {0.25, 0.5, 1.0}
    data = json.loads((out / "fig2.json").read_text("utf-8"))
    assert data["meta"]["seeds"] == [1] and len(data["rows"]) == len(rows)
    assert (out / "fig2.png").read_bytes()[:8] == PNG_MAGIC
    html = (out / "fig2.html").read_text("utf-8")
    assert "<html" in html.lower() and "Bokeh" in html


def test_figure3_writes_html_and_png(tmp_path, capsys):
    assert main(["figure3", "--horizon", "2", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "sigma = 20" in out and "sigma = 200" in out
    assert (tmp_path / "fig3.png").read_bytes()[:8] == PNG_MAGIC
    assert "Bokeh" in (tmp_path / "fig3.html").read_text("utf-8")


def test_serve_delegates_or_explains(monkeypatch, capsys):
    seen = []
    fake = types.SimpleNamespace(main=lambda argv: seen.append(argv) or 0)
    monkeypatch.setitem(sys.modules, "app.serving.serve", fake)
    assert main(["serve", "--port", "0"]) == 0 and seen == [["--port", "0"]]
    monkeypatch.setitem(sys.modules, "app.serving.serve", None)  # as if the module were absent
    assert main(["serve"]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_dashboard_sweep_points_are_what_isl_sweep_prints(tmp_path, capsys):
    """One path: the ν-sweep tab's points are the core's sweep — digit for digit what ``isl sweep`` writes for the
    same α, β, m, σ, ν grid, horizon and seed (α = 0: a model outside paper A's w-parametrization)."""
    from app.sweeps import BATCHES, SIM_LEVELS, simulate_points

    pts = simulate_points(0.0, 3.0, 2, [2.0, 20.0], horizon=20.0, seed=4)
    argv = [
        "sweep",
        "--alphas",
        "0",
        "--beta",
        "3",
        "--m",
        "2",
        "--sigmas",
        "2",
        "20",
        "--horizon",
        "20",
        "--ell-min",
        str(int(SIM_LEVELS[0])),
        "--ell-max",
        str(int(SIM_LEVELS[-1])),
        "--seeds",
        "4",
        "--batches",
        str(BATCHES),
        "--no-png",
        "--quiet",
        "--out",
        str(tmp_path),
    ]
    assert main(argv) == 0
    capsys.readouterr()
    data = json.loads((tmp_path / "fig2.json").read_text("utf-8"))
    assert data["meta"]["beta"] == 3.0 and data["meta"]["w"] is None
    rows = data["rows"]
    assert len(rows) == 2 * len(SIM_LEVELS) * 2
    for row in rows:
        j, k, i = [2.0, 20.0].index(row["sigma"]), list(pts.nu_over_beta).index(row["nu_over_beta"]), row["i"] - 1
        dashboard = (
            pts.ratio[j, k, i],
            pts.low[j, k, i],
            pts.high[j, k, i],
            pts.kbf[j, i],
            pts.kbf_low[j, i],
            pts.kbf_high[j, i],
        )
        cli = (row["ratio"], row["ratio_low"], row["ratio_high"], row["kbf_ratio"], row["kbf_low"], row["kbf_high"])
        assert [repr(float(x)) for x in dashboard] == [repr(x) for x in cli], row


def test_dashboard_worst_case_table_is_what_isl_worstcase_prints(capsys):
    """One path: the worst-case tab's table is the core's worst case — digit for digit what ``isl worstcase
    --json`` prints for the same α, σ range, m, w, design σ, horizon and seed (the tab's one seed, 10 batches)."""
    from app.extras import worst_case_table

    table = worst_case_table(
        [1.0], sigma_range=(2.0, 200.0), n_sigma=2, m=2, w=3.0, sigma_design=20.0, horizon=20.0, seed=7
    )
    assert (
        main(
            [
                "worstcase",
                "--alphas",
                "1",
                "--sigma-min",
                "2",
                "--sigma-max",
                "200",
                "--n-sigma",
                "2",
                "--m",
                "2",
                "--w",
                "3",
                "--sigma-design",
                "20",
                "--horizon",
                "20",
                "--seeds",
                "7",
                "--batches",
                "10",
                "--json",
            ]
        )
        == 0
    )
    cli = _json(capsys)["rows"]
    dashboard = json.loads(json.dumps(table.records()), parse_constant=lambda c: None)
    keys = ("filter", "worst", "worst_low", "worst_high", "worst_sigma", "worst_i", "nu", "sigma_design")
    assert len(cli) == len(dashboard) == len(table.names) >= 5
    for mine, theirs in zip(dashboard, cli, strict=True):
        assert [repr(mine[k]) for k in keys] == [repr(theirs[k]) for k in keys], mine["filter"]


def test_the_page_shows_the_version_isl_version_prints(capsys):
    """One version string: the dashboard's header shows what ``isl --version`` (the console script) prints."""
    from app.views.about import docs_link

    assert main(["--version"]) == 0
    printed = capsys.readouterr().out.strip()
    assert printed.startswith("isl ") and len(printed) > 4
    assert f'<span class="isl-version">{printed}</span>' in docs_link().object
