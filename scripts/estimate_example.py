"""The README's example of ``oilwatch estimate``: a plant run written out as a record, then estimated.

The in-process plant (full model) at 1 kHz for 8 s, bearing 1's supply dropping from 100 % to 75 %
(sigmoid centred at 4 s, 0.1 s), 1 um probe noise; the record loses 50 ms of data at 2.5 s (a gap,
bridged) and probe y2 reads nothing for 0.5 s from 6 s. Writes docs/estimate_example/record.csv and the
estimate's files beside it, and copies the four views to docs/images/estimate_<view>.png for the guide.

    OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg python scripts/estimate_example.py
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from fixtures.plant_records import plant_run  # noqa: E402

from oilwatch.cli import main  # noqa: E402
from oilwatch.monitoring.views import VIEW_FILES  # noqa: E402
from oilwatch.records.writers import write_record  # noqa: E402

OUT = ROOT / "docs" / "estimate_example"


def make_record(path: Path) -> Path:
    t, _, measured, _ = plant_run(8.0, 1e-3, 1.0, drop_at_s=4.0)
    keep = ~((t > 2.5) & (t <= 2.55))
    columns = {"time_s": t[keep]}
    for i, name in enumerate(("x1", "y1", "x2", "y2")):
        values = measured[keep, i] * 1e6
        if name == "y2":
            values[(t[keep] > 6.0) & (t[keep] <= 6.5)] = np.nan
        columns[f"{name}_um"] = values
    return write_record(path, columns)


if __name__ == "__main__":
    OUT.mkdir(parents=True, exist_ok=True)
    record = make_record(OUT / "record.csv")
    code = main(["estimate", str(record), "--out", str(OUT), "--no-progress"])
    for name in VIEW_FILES.values():
        shutil.copyfile(OUT / name, OUT.parent / "images" / f"estimate_{name}")
    sys.exit(code)
