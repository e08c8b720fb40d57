"""``isl data``: the fit and the diagnostics as JSON, the same numbers as the core's; bad input → one line, code 2."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("statsmodels", reason="the data extra: pip install 'isl[data]'")

from isl_core.cli import main
from isl_core.series import fit
from isl_core.series.sources import dataset


def test_isl_data_nile_json_equals_the_core(capsys):
    assert main(["data", "nile", "--m", "1", "--alpha", "0", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    ref = fit(dataset("nile").head(80), 1, alpha=0.0)
    for key in ("m", "alpha", "beta", "sigma", "beta_se", "sigma_se", "loglik", "aic", "bic"):
        assert out["fit"][key] == pytest.approx(ref.as_dict()[key], rel=1e-12), key
    assert out["fit"]["alpha_se"] is None  # α fixed: no standard error, null in JSON
    names = [d["name"] for d in out["diagnostics"]]
    assert names == ["kalman", "isl", "isl_model", "kbf_adaptive", "vb", "kbf_robust", "imm"]
    kalman = out["diagnostics"][0]
    assert kalman["n"] == 20 and 0.0 < kalman["ljung_box_p"] <= 1.0 and kalman["nis"] > 0


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["data", "nowhere.csv"], "SOURCE 'nowhere.csv' is neither"),
        (["data", "nile", "--m", "7"], "m must be an integer >= 1 and <= 6"),
        (["data", "nile", "--alpha", "-1"], "expected a finite number >= 0"),
        (["data", "nile", "--time", "year"], "--time and --value choose a CSV file's columns"),
        (["data", "nile", "--holdout", "0.99"], "holdout must be"),
        (["data", "CSV", "--value", "nope"], "column 'nope' is not in the file"),
    ],
)
def test_isl_data_bad_input_names_the_argument(argv, needle, capsys, tmp_path):
    path = tmp_path / "x.csv"
    path.write_text("t,v\n" + "".join(f"{i},{i % 3}\n" for i in range(20)))
    argv = [str(path) if a == "CSV" else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
