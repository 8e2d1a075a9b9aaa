"""The robustness rows of the free-factor ramp cases with the start bank, on the cached plant records.

The records ``<records>/<case>_<q1>_<q2>_60.npz`` are the robustness plant's (``RobustnessRun.record``
at the report's settings: 60 s, 1 um, seed 1); each row is ``RobustnessRun.run_case`` on its record, so
the row is the report's row (the runner uses :class:`oilwatch.estimator.start_bank.StartBank` where it
applies).

    python scripts/start_bank_rows.py RECORDS OUT
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from oilwatch.robustness.cases import case_by_name
from oilwatch.robustness.runner import REPORT_SETTINGS, RobustnessRun, format_table

SETTINGS = REPORT_SETTINGS
ROWS = [
    ("temperature-ramp", (100.0, 100.0)),
    ("temperature-ramp", (80.0, 90.0)),
    ("speed-ramp", (100.0, 100.0)),
    ("speed-ramp", (80.0, 90.0)),
]


class CachedRun(RobustnessRun):
    """The run with each record read from the cache."""

    records = Path(".")
    """The folder of the cached records (the script's first argument)."""

    def record(self, case, point_pct, seed, after_baseline=True):
        data = np.load(self.records / f"{case.name}_{point_pct[0]:g}_{point_pct[1]:g}_60.npz")
        return data["measured"], data["speed"], data["temperature"]


def main() -> None:
    CachedRun.records = Path(sys.argv[1])
    out = Path(sys.argv[2])
    out.mkdir(parents=True, exist_ok=True)
    run = CachedRun(SETTINGS)
    rows = []
    for name, point in ROWS:
        rows.append(run.run_case(case_by_name(name), point))
        print(rows[-1]["case"], point, rows[-1]["error_pct"], rows[-1]["std_pct"], flush=True)
        (out / "robustness.json").write_text(
            json.dumps({"settings": SETTINGS, "rows": rows}, indent=1) + "\n"
        )
    print("\n".join(format_table(rows)))


if __name__ == "__main__":
    main()
