"""The docs' robustness result files (docs/results/robustness/*/robustness.json) are what ``oilwatch
robustness`` computes today: a sample of their rows, recomputed from each file's own settings.

The sample covers a single filter primed by a baseline whose offsets drift during the run (the static
change's std widening), the start bank on the compressor with every probe's sensitivity off and no baseline
(its leading start's reports, a model mismatch held with the flowrates' prior std), and a model-structure
plant. Figures agree to 1e-4 of themselves (code changes move the last digits of a row
through the filter's 60 000 steps by a few 1e-6), flags exactly.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from oilwatch.robustness.case_run import RobustnessRun
from oilwatch.robustness.cases import case_by_name

RESULTS = Path(__file__).resolve().parents[1] / "docs" / "results" / "robustness"
SAMPLE = (
    ("offsets_unbalance_runout_probes", "offsets-drift", (100.0, 100.0)),
    ("compressor", "sensitivity", (80.0, 90.0)),
    ("model_structure", "bow", (80.0, 90.0)),
)
FIGURES = ("error_pct", "std_pct", "consistent_fraction", "mismatch_fraction", "filter_error_pct")
FLAGS = ("within_2_std", "within_tolerance", "false_alarm", "detected", "flagged_probes", "alarms_consistent")


@pytest.mark.slow
@pytest.mark.parametrize(("folder", "name", "point"), SAMPLE)
def test_a_stored_robustness_row_is_what_the_command_computes(folder, name, point):
    document = json.loads((RESULTS / folder / "robustness.json").read_text())
    stored = next(
        row for row in document["rows"] if row["case"] == name and (row["q1_pct"], row["q2_pct"]) == point
    )
    row = RobustnessRun(document["settings"]).run_case(case_by_name(name), point)
    for key in FIGURES:
        np.testing.assert_allclose(row[key], stored[key], rtol=1e-4, atol=1e-9, err_msg=key)
    assert {key: row[key] for key in FLAGS} == {key: stored[key] for key in FLAGS}
