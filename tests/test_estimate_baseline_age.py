"""The baseline's age in ``oilwatch estimate``: ``--record-start`` against the baseline file's
``record_start_utc`` (which ``oilwatch baseline --record-start`` stores). The offsets' prior widens by the
machine file's ``[probes] offset_drift_um_per_day`` over it (0.1 um/day for the turbine: 10 um after 100
days, beside the baseline's 0.5 um), and either time unknown leaves the prior as the baseline gives it."""

from __future__ import annotations

import json

import numpy as np
import pytest
from fixtures.plant_records import plant_run, read_estimates
from test_misuse import one_line_error

from oilwatch.cli import main
from oilwatch.models.validation import InputError
from oilwatch.monitoring.baseline_age import baseline_age_days
from oilwatch.records.writers import write_record

PROBES = ("x1", "y1", "x2", "y2")
COMMISSIONED = "2026-08-23T08:00:00Z"
HUNDRED_DAYS_LATER = "2026-12-01T08:00:00+00:00"


def _baseline(path, record_start: str | None) -> None:
    document = {
        "format": "oilwatch commissioning baseline",
        "format_version": 1,
        "flowrates_ml_min": [596.3, 596.3],
        "offsets_um": [0.0] * 4,
        "offset_std_um": [0.5] * 4,
        "offset_covariance_um2": (0.25 * np.eye(4)).tolist(),
        "samples": 4000,
    }
    if record_start is not None:
        document["record_start_utc"] = record_start
    path.write_text(json.dumps(document))


def test_the_age_is_the_record_start_minus_the_baseline_s_and_unknown_when_either_is(tmp_path):
    dated, undated = tmp_path / "dated.json", tmp_path / "undated.json"
    _baseline(dated, COMMISSIONED)
    _baseline(undated, None)
    assert baseline_age_days(dated, HUNDRED_DAYS_LATER) == pytest.approx(100.0, abs=1e-9)
    assert baseline_age_days(dated, "2026-12-01T09:00:00+01:00") == pytest.approx(100.0, abs=1e-9)
    assert baseline_age_days(dated, None) is None
    assert baseline_age_days(undated, HUNDRED_DAYS_LATER) is None
    with pytest.raises(InputError, match="before the baseline's record"):
        baseline_age_days(dated, "2026-08-01T00:00:00Z")


def test_estimate_widens_the_offsets_prior_by_the_drift_over_the_baseline_s_age(tmp_path, capsys):
    t, _, measured, _ = plant_run(0.2, 1e-3, 1.0, seed=4)
    record = tmp_path / "record.csv"
    write_record(record, {"time_s": t, **{f"{n}_um": measured[:, i] * 1e6 for i, n in enumerate(PROBES)}})
    baseline = tmp_path / "baseline.json"
    _baseline(baseline, COMMISSIONED)
    runs = {}
    for name, extra in (("aged", ["--record-start", HUNDRED_DAYS_LATER]), ("unknown", [])):
        out = tmp_path / name
        argv = ["estimate", str(record), "--baseline", str(baseline), "--out", str(out), "--no-views"]
        assert main([*argv, "--no-progress", *extra]) == 0
        runs[name] = (json.loads((out / "summary.json").read_text()), read_estimates(out))
    assert runs["aged"][0]["estimator"]["baseline_age_days"] == pytest.approx(100.0)
    assert runs["unknown"][0]["estimator"]["baseline_age_days"] is None
    # after the first update: the prior's std shrunk by that one sample, sqrt(0.5^2 + 10^2) against 0.5 um
    for n in PROBES:
        aged, unknown = runs["aged"][1][f"offset_{n}_std_um"][0], runs["unknown"][1][f"offset_{n}_std_um"][0]
        assert unknown == pytest.approx(0.5, rel=0.05) and aged > 5.0 * unknown, (n, aged, unknown)
    written = tmp_path / "written.json"  # oilwatch baseline stores its record's start
    dated = ["--record-start", COMMISSIONED, "--out", str(written)]
    assert main(["baseline", "--record", str(record), *dated]) == 0
    assert json.loads(written.read_text())["record_start_utc"] == "2026-08-23T08:00:00+00:00"
    line = one_line_error(capsys, [*argv, "--record-start", "yesterday"])
    assert "--record-start" in line and "ISO 8601" in line
    line = one_line_error(capsys, [*argv, "--record-start", "2026-08-01T00:00:00Z"])
    assert "before the baseline's record" in line
