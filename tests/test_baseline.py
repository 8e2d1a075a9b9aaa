"""``oilwatch baseline``: probe offsets from a record at known flowrates, and their use as the prior."""

from __future__ import annotations

import numpy as np
import pytest
from fixtures.toy_model import NOMINAL_FLOWRATE_M3_S

from oilwatch.cli import main
from oilwatch.estimator.baseline import load_baseline
from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.models.system.augmented import GridAugmentedModel
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.plant import RotorBearingPlant
from oilwatch.models.validation import InputError

QN = NOMINAL_FLOWRATE_M3_S
DT = 1e-3
OFFSETS = np.array([-12e-6, 20e-6, 7e-6, -18e-6])


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    plant = RotorBearingPlant(load_system(reduced=False), DT, None, 1e-6, 21, initial_flowrates_m3_s=(QN, QN))
    data = np.array([plant.step((QN, QN)).measured_position_m for _ in range(3000)]) + OFFSETS
    path = tmp_path_factory.mktemp("baseline") / "commissioning.csv"
    times = DT * np.arange(1, len(data) + 1)
    table = np.column_stack([times, data * 1e6, np.full(len(data), 75.0)])
    header = "time_s,x1_um,y1_um,x2_um,y2_um,speed_hz"
    np.savetxt(path, table, delimiter=",", header=header, comments="", fmt="%.9g")
    return path, data


def test_the_baseline_recovers_the_offsets_and_primes_the_estimator(record, tmp_path, capsys):
    path, data = record
    out = tmp_path / "baseline.json"
    assert main(["baseline", "--record", str(path), "--out", str(out), "--preset", "paper"]) == 0
    assert "offsets [um]" in capsys.readouterr().out
    baseline = load_baseline(out)
    offsets, std = np.array(baseline.offsets_m), np.array(baseline.std_m)
    assert (np.abs(offsets - OFFSETS) < np.maximum(3.0 * std, 0.3e-6)).all() and (std < 1e-6).all()
    # primed with the baseline, the estimator reads the flowrate, not the offsets (20 um would read +100 %)
    model = GridAugmentedModel(load_system(reduced=True), DT)
    primed = OilFlowEKF(model, EKFConfig.recommended(first_sample_time_s=DT, offset_baseline=baseline))
    trace = primed.run(data)
    assert np.abs(trace.q_m3_s[2000:].mean(axis=0) / QN - 1).max() < 0.02


def test_a_baseline_its_model_cannot_explain_is_written_and_exits_3(record, tmp_path, capsys):
    """A commissioning record with 5 um of 2x on one probe (no model the estimator has makes it): the file is
    written, the line says the model explained the record only part of the time, and the exit status is 3,
    as for an estimate it cannot trust (docs/operations.md)."""
    _, data = record
    times = DT * np.arange(1, len(data) + 1)
    disturbed = data.copy()
    disturbed[:, 1] += 5e-6 * np.sin(2.0 * np.pi * 150.0 * times)
    bad = tmp_path / "disturbed.csv"
    table = np.column_stack([times, disturbed * 1e6, np.full(len(data), 75.0)])
    np.savetxt(bad, table, delimiter=",", header="time_s,x1_um,y1_um,x2_um,y2_um,speed_hz", comments="")
    out = tmp_path / "baseline.json"
    assert main(["baseline", "--record", str(bad), "--out", str(out), "--preset", "paper"]) == 3
    assert "its model explained the record only" in capsys.readouterr().out
    assert load_baseline(out) is not None


def test_bad_records_are_named(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,x1_um,y1_um\n0.001,1,2\n")
    assert main(["baseline", "--record", str(bad), "--out", str(tmp_path / "b.json")]) == 2
    assert "missing column 'x2_um' (probes.x2.column)" in capsys.readouterr().err
    assert main(["baseline", "--record", str(tmp_path / "none.csv"), "--out", str(tmp_path / "b.json")]) == 2
    assert "no such record file" in capsys.readouterr().err
    with pytest.raises(InputError, match="not an oilwatch commissioning baseline"):
        bad.write_text("{}")
        load_baseline(bad)


def test_a_2_khz_record_is_read_as_estimate_reads_it(tmp_path, capsys):
    """The baseline's record comes in through estimate's reader: a 2 kHz record (refused before: "samples must
    be 0.001 s apart") is anti-aliased onto the 1 kHz grid and gives the offsets, with the probes named
    by the machine file's [probes] mapping overridden from the command line."""
    fine = 0.5 * DT
    plant = RotorBearingPlant(
        load_system(reduced=False), fine, None, 1e-6, 22, initial_flowrates_m3_s=(QN, QN)
    )
    data = np.array([plant.step((QN, QN)).measured_position_m for _ in range(6000)]) + OFFSETS
    path = tmp_path / "fast.csv"
    times = fine * np.arange(1, len(data) + 1)
    header = "time_s,A,B,C,D"
    np.savetxt(
        path, np.column_stack([times, data * 1e6]), delimiter=",", header=header, comments="", fmt="%.9g"
    )
    out = tmp_path / "baseline.json"
    names = [
        f"--probe={probe}.column={column}"
        for probe, column in zip(("x1", "y1", "x2", "y2"), "ABCD", strict=True)
    ]
    assert main(["baseline", "--record", str(path), "--out", str(out), "--preset", "paper", *names]) == 0
    baseline = load_baseline(out)
    offsets, std = np.array(baseline.offsets_m), np.array(baseline.std_m)
    assert (np.abs(offsets - OFFSETS) < np.maximum(3.0 * std, 0.3e-6)).all()
