"""``oilwatch run``'s result.csv is a record (issue 15): it carries ``time_s`` and the plant's probe signals
in um along each probe's axis under the record format's names, so ``oilwatch estimate <run>/result.csv`` and
``oilwatch baseline --record <run>/result.csv`` read it directly. The run goes through the FMUs in a fresh
process; the estimate on its record reproduces the co-simulated estimator's flowrates."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
from fixtures.fmu_subprocess import REPO_ROOT

from oilwatch.cli import main
from oilwatch.scenarios.runner import read_result

NOMINAL = 596.3


def test_a_run_s_result_csv_is_a_record_for_estimate_and_baseline(built_fmus, tmp_path):
    run_dir = tmp_path / "run"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(REPO_ROOT))
    command = [sys.executable, "-m", "oilwatch", "run", "constant", "--q1-pct", "80", "--duration-s", "2",
               "--fmu-dir", str(built_fmus), "--out", str(run_dir), "--no-progress"]  # fmt: skip
    process = subprocess.run(command, env=env, cwd=REPO_ROOT, capture_output=True, text=True, timeout=600)
    assert process.returncode == 0, process.stderr
    result = read_result(run_dir / "result.csv")
    assert {"time_s", "x1_um", "y1_um", "x2_um", "y2_um"} <= set(result)

    out = tmp_path / "estimate"
    arguments = [
        "estimate",
        str(run_dir / "result.csv"),
        "--out",
        str(out),
        "--no-views",
        "--no-progress",
        "--offset-prior-um",
        "0",
        "--operating-point",
        "nominal",
    ]  # fmt: skip  (the run's estimator: offsets known and the nominal model, the FMU's defaults)
    assert main(arguments) == 0
    summary = json.loads((out / "summary.json").read_text())
    lines = (out / "estimates.csv").read_text().splitlines()
    header = lines[0].split(",")
    ours = np.array([[float(x) if x else np.nan for x in line.split(",")] for line in lines[1:]])
    assert summary["samples"] == len(result["time_s"])
    late = result["time_s"] > 1.0  # after the start, where the co-simulated filter skipped the t = 0 row
    for b in (1, 2):
        column = ours[:, header.index(f"q{b}_est_ml_min")]
        gap = np.abs(column[late] - result[f"q{b}_est_ml_min"][late])
        assert gap.max() < 0.001 * NOMINAL, (b, gap.max())

    baseline = tmp_path / "baseline.json"
    arguments = ["baseline", "--record", str(run_dir / "result.csv"), "--out", str(baseline),
                 "--q1-ml-min", str(0.8 * NOMINAL)]  # fmt: skip
    assert main(arguments) == 0
    document = json.loads(baseline.read_text())
    assert document["samples"] == len(result["time_s"])
    assert np.all(np.abs(document["offsets_um"]) < 3.0 * np.array(document["offset_std_um"]) + 0.5)
