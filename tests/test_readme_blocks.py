"""README tables written by the commands between their markers (oilwatch/cli/readme_block.py)."""

from __future__ import annotations

import json

import pytest

from oilwatch.cli import main
from oilwatch.cli.readme_block import replace_block
from oilwatch.models.validation import InputError
from oilwatch.study.readme_tables import main as study_tables


def test_a_block_is_replaced_between_its_markers_and_a_missing_one_is_named(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text("head\n<!-- generated t: old command -->\nold\n<!-- /generated t -->\ntail\n")
    replace_block(readme, "t", "| a |\n", "new command")
    assert (
        readme.read_text() == "head\n<!-- generated t: new command -->\n| a |\n<!-- /generated t -->\ntail\n"
    )
    with pytest.raises(InputError, match="no block '<!-- generated other"):
        replace_block(readme, "other", "x", "c")


def test_the_robustness_and_study_tables_come_from_their_json(tmp_path, capsys):
    row = {
        "case": "none",
        "q1_pct": 100.0,
        "q2_pct": 100.0,
        "error_pct": [0.1, -0.2],
        "std_pct": [1.0, 1.1],
        "within_tolerance": True,
        "within_2_std": True,
        "false_alarm": False,
        "alarms_consistent": None,
        "detected": [],
        "flagged_probes": [],
        "consistent_fraction": 1.0,
        "mismatch_fraction": 0.25,
        "error_over_bound": [0.2, 0.3],
    }
    first, second = tmp_path / "a.json", tmp_path / "b.json"
    first.write_text(json.dumps({"rows": [row]}))
    older = {key: value for key, value in row.items() if key != "mismatch_fraction"}  # a file made before it
    second.write_text(json.dumps({"rows": [{**older, "error_pct": [0.5, 0.6]}]}))
    readme = tmp_path / "README.md"
    readme.write_text("<!-- generated robustness: x -->\n<!-- /generated robustness -->\n")
    assert main(["robustness", "--from-json", str(first), str(second), "--readme", str(readme)]) == 0
    assert "| none | 100/100 | +0.50 / +0.60 |" in readme.read_text()
    assert "| 1.00 | - | 0.2 / 0.3 |" in readme.read_text()
    line = "Truth within +-2 std at the end: 1 of 1 rows of the acceptance cases (100 %)"
    assert line in readme.read_text()
    # a second table on the page has a block of its own name; the first one is left as it was
    first_block = readme.read_text()
    readme.write_text(first_block + "<!-- generated robustness-b: x -->\n<!-- /generated robustness-b -->\n")
    assert (
        main(["robustness", "--from-json", str(first), "--readme", str(readme), "--block", "robustness-b"])
        == 0
    )
    assert readme.read_text().startswith(first_block)
    assert "| none | 100/100 | +0.10 / -0.20 |" in readme.read_text().split("robustness-b", 1)[1]
    level = {
        "noise_um": 1.0,
        "n_cases": 4,
        "n_expected": 4,
        "mean_err_pct": 0.05,
        "std_err_pct": 0.04,
        "max_err_pct": 0.28,
        "mean_crlb_ratio": 1.4,
        "bias_pct_b1": 0.01,
        "bias_pct_b2": -0.02,
        "mean_std_pct": 0.31,
        "within_2std_fraction": 0.95,
        "paper": {"mean_err_pct": 1.82, "std_err_pct": 0.99, "max_err_pct": 5.06},
    }
    study = tmp_path / "known"
    study.mkdir()
    (study / "summary.json").write_text(
        json.dumps({"settings": {"case_model": "direct"}, "noise_levels": [level], "timing": {"wall_s": 600}})
    )
    readme.write_text("<!-- generated study-nuisances: x -->\n<!-- /generated study-nuisances -->\n")
    assert study_tables(["--readme", str(readme), f"known={study}"]) == 0
    assert (
        "| known | direct | 1 | 4/4 | 0.05 (1.82) | 0.04 (0.99) | 0.28 (5.06) | +0.01 / -0.02 | 0.31 | 95% "
        "| 1.40 | 10 min |" in readme.read_text()
    )
