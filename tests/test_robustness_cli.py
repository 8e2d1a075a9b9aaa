"""``oilwatch robustness``: the machinery on a short record (the figures need 60 s: see the README)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from oilwatch.cli import main
from oilwatch.robustness import CASES, POINTS_PCT


@pytest.mark.slow  # runs the cases; the module's other tests keep the command in the fast tier
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
    document = json.loads(path.read_text())
    rows = document["rows"]
    assert rows[0]["error_pct"] == [123.0, 456.0] and rows[-1] == dropped

    # ... and none that another version of oilwatch made: the table never mixes two versions' rows
    document["sources"] = "0" * 16
    path.write_text(json.dumps(document))
    assert main(arguments) == 0
    message = capsys.readouterr().err
    assert "0 of 4 rows kept" in message and "another version of oilwatch made it" in message
    rows = json.loads(path.read_text())["rows"]
    assert rows[0]["error_pct"] != [123.0, 456.0] and rows[1:] == document["rows"][1:]


def test_a_machine_file_is_recorded_by_its_absolute_path(tmp_path, monkeypatch, capsys):
    """robustness.json's settings name the machine --from-json loads again for the rows' bounds: a file
    given relative to the run's folder is found from another folder (a bundled machine stays a name)."""
    import shutil

    import oilwatch.robustness
    from oilwatch.models.machine import BUNDLED_MACHINES

    run_folder, other = tmp_path / "run", tmp_path / "other"
    run_folder.mkdir(), other.mkdir()
    shutil.copy(BUNDLED_MACHINES["turbine"], run_folder / "mine.toml")
    recorded = []

    def run_robustness(cases, machine_file, **settings):
        recorded.append(machine_file)
        return []

    monkeypatch.setattr(oilwatch.robustness, "run_robustness", run_robustness)
    monkeypatch.chdir(run_folder)
    for machine in ("mine.toml", "compressor"):
        assert main(["robustness", "--machine", machine, "--cases", "none", "--out", "rob"]) == 0
    capsys.readouterr()
    assert recorded == [str((run_folder / "mine.toml").resolve()), "compressor"]
    monkeypatch.chdir(other)
    settings = {"machine_file": recorded[0], "duration_s": 60.0, "noise_um": 1.0, "seed": 1,
                "offset_prior_um": 25.0, "unbalance_prior": 2.0, "viscosity_prior": 0.1}  # fmt: skip
    (other / "robustness.json").write_text(json.dumps({"settings": settings, "rows": []}))
    assert main(["robustness", "--from-json", "robustness.json"]) == 0


def test_an_unknown_case_is_named(tmp_path, capsys):
    assert main(["robustness", "--cases", "earthquake", "--out", str(tmp_path)]) == 2
    error = capsys.readouterr().err
    assert "earthquake" in error and CASES[0].name in error


def test_a_chain_applied_to_the_shared_true_motion_is_the_plant_with_that_chain():
    """The run simulates each plant variant once and applies each case's probes to its true motion: the
    record must be bit-identical to a plant built with the case's measurement chain."""
    import dataclasses

    from oilwatch.models.system.plant import RotorBearingPlant
    from oilwatch.robustness import case_by_name
    from oilwatch.robustness.case_run import DT_S, RobustnessRun

    settings = dict(machine_file=None, duration_s=0.3, noise_um=1.0, seed=4, offset_prior_um=25.0,
                    unbalance_prior=2.0, viscosity_prior=0.1)  # fmt: skip
    run = RobustnessRun(settings)
    case = dataclasses.replace(case_by_name("stuck"), offsets=True, runout=True, sensitivity=True)
    case = dataclasses.replace(case, unbalance=(1.5, 40.0), mounting_angle_deg=45.0)
    measured, _, _ = run.record(case, (80.0, 90.0), 4)
    q = tuple(p / 100.0 * q for p, q in zip((80.0, 90.0), run.nominal_m3_s, strict=True))
    system, chain = run.plant_system(case), run.chain(case, True)
    plant = RotorBearingPlant(system, DT_S, None, run.noise_m, 4, initial_flowrates_m3_s=q, chain=chain)
    direct = np.array([plant.step(q).measured_position_m for _ in range(len(measured))])
    assert np.array_equal(measured, direct, equal_nan=True)


def test_the_offset_step_case_moves_the_offsets_since_a_baseline_its_age_trusts_to_3_um():
    from oilwatch.estimator.offset_baseline import OffsetBaseline
    from oilwatch.models.machine import load_machine
    from oilwatch.models.probes import read_probes
    from oilwatch.robustness.cases import BASELINE_AGE_DAYS, DRIFT_M, case_by_name, probe_errors

    case = case_by_name("offsets-step")
    before = np.array([p.zero_offset_m for p in probe_errors(case, 1, 60.0, after_baseline=False)])
    after = np.array([p.zero_offset_m for p in probe_errors(case, 1, 60.0, after_baseline=True)])
    assert np.allclose(np.abs(after - before), DRIFT_M)
    assert all(p.zero_drift_m_s == 0.0 for p in probe_errors(case, 1, 60.0, after_baseline=True))
    # the turbine's [probes] drift rate times the baseline's age widens the offsets' prior to 3 um
    drift = read_probes(load_machine(None)).offset_drift_m_per_day
    baseline = OffsetBaseline(
        offsets_m=(0.0,) * 4,
        std_m=(1e-12,) * 4,
        age_s=BASELINE_AGE_DAYS * 86400.0,
        drift_m_per_day=drift,
    )
    assert np.allclose(baseline.offset_prior_std_m(), DRIFT_M, rtol=1e-6)
