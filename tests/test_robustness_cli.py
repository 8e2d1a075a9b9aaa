"""``oilwatch robustness``: the machinery on a short record (the figures need 60 s: see the README)."""

from __future__ import annotations

import json

import numpy as np

from oilwatch.cli import main
from oilwatch.robustness import CASES, POINTS_PCT


def test_a_short_run_writes_one_row_per_case_and_point(tmp_path, capsys):
    out = tmp_path / "rob"
    code = main(["robustness", "--duration-s", "2", "--cases", "huge", "none", "--out", str(out)])
    assert code == 0
    rows = json.loads((out / "robustness.json").read_text())["rows"]
    assert [(r["case"], (r["q1_pct"], r["q2_pct"])) for r in rows] == [
        (name, point) for name in ("huge", "none") for point in POINTS_PCT
    ]
    huge = [r for r in rows if r["case"] == "huge"]
    assert all(r["fault_flagged"] and r["flagged_probes"] == [1] for r in huge)
    assert all(not r["flagged_probes"] for r in rows if r["case"] == "none")
    for r in rows:
        assert np.all(np.isfinite(r["error_pct"])) and min(r["std_pct"]) > 0.0 and min(r["bound_pct"]) > 0.0
    assert "| huge | 100/100 |" in capsys.readouterr().out
    assert (out / "robustness.md").read_text().startswith("| case |")

    # --resume keeps the rows of the same settings and runs only the missing one
    path = out / "robustness.json"
    document = json.loads(path.read_text())
    document["rows"][0]["error_pct"] = [123.0, 456.0]  # a marker: a kept row is not recomputed
    dropped = document["rows"].pop()
    path.write_text(json.dumps(document))
    arguments = ["robustness", "--duration-s", "2", "--cases", "huge", "none", "--out", str(out), "--resume"]
    assert main(arguments) == 0
    assert "3 of 4 rows kept" in capsys.readouterr().err
    rows = json.loads(path.read_text())["rows"]
    assert rows[0]["error_pct"] == [123.0, 456.0] and rows[-1] == dropped


def test_an_unknown_case_is_named(tmp_path, capsys):
    assert main(["robustness", "--cases", "earthquake", "--out", str(tmp_path)]) == 2
    error = capsys.readouterr().err
    assert "earthquake" in error and CASES[0].name in error
