"""``oilwatch estimate`` subtracts the probes' slow-roll runout given by the machine file's ``[probes]``
``runout_*`` keys (or a baseline's) at each sample's rotor angle: a record with runout then gives the
estimates of the same record without it, where the uncompensated run is off; runout with probes that cannot
be read along their axes is a one-line error."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from fixtures.fmu_subprocess import REPO_ROOT
from fixtures.plant_records import SPEED_HZ, plant_run, read_estimates

from oilwatch.cli import main
from oilwatch.estimator.runout import SlowRollVectors
from oilwatch.monitoring.trust import UNTRUSTED_EXIT_CODE
from oilwatch.records.writers import write_record

PROBES = ("x1", "y1", "x2", "y2")
ONCE_UM = (3.0, 2.0, 2.5, 1.5)
ONCE_PHASE_DEG = (20.0, -110.0, 75.0, 160.0)
TWICE_UM = (1.0, 0.6, 0.8, 1.2)
TWICE_PHASE_DEG = (-40.0, 10.0, 130.0, -150.0)
NOMINAL = 596.3


def _vectors(amplitudes_um, phases_deg) -> tuple:
    return tuple(
        a * 1e-6 * np.exp(1j * math.radians(p)) for a, p in zip(amplitudes_um, phases_deg, strict=True)
    )


def _runout_keys() -> str:
    text = ""
    for k, name in enumerate(PROBES):
        text += (
            f"\n[probes.{name}]\nrunout_1x_um = {ONCE_UM[k]}\nrunout_1x_phase_deg = {ONCE_PHASE_DEG[k]}\n"
            f"runout_2x_um = {TWICE_UM[k]}\nrunout_2x_phase_deg = {TWICE_PHASE_DEG[k]}\n"
        )
    return text


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """A 2 s plant run at nominal flow, 0.5 um noise, written without and with the probes' runout (the
    plant's rotor angle is 2 pi f t), and the machine file with the runout keys."""
    folder = tmp_path_factory.mktemp("runout")
    t, _, measured, _ = plant_run(2.0, 1e-3, 0.5)
    vectors = SlowRollVectors(
        tuple(a * 1e-6 * np.exp(1j * math.radians(p)) for a, p in zip(ONCE_UM, ONCE_PHASE_DEG, strict=True)),
        tuple(
            a * 1e-6 * np.exp(1j * math.radians(p)) for a, p in zip(TWICE_UM, TWICE_PHASE_DEG, strict=True)
        ),
        (0.0,) * 4,
        (0.0,) * 4,
    )
    with_runout = measured + vectors.runout_m(2.0 * math.pi * SPEED_HZ * t)
    paths = {}
    for name, signals in (("clean", measured), ("runout", with_runout)):
        columns = {"time_s": t, **{f"{n}_um": signals[:, i] * 1e6 for i, n in enumerate(PROBES)}}
        paths[name] = write_record(folder / f"{name}.csv", columns)
    machine = folder / "turbine.toml"
    machine.write_text((REPO_ROOT / "models" / "turbine.toml").read_text(encoding="utf-8") + _runout_keys())
    (folder / "tables").symlink_to(REPO_ROOT / "models" / "tables")
    return paths, machine


def _flowrates(record, out, *extra, code=0) -> np.ndarray:
    assert main(["estimate", str(record), "--out", str(out), "--no-progress", "--no-views", *extra]) == code
    estimates = read_estimates(out)
    return np.column_stack([estimates["q1_est_ml_min"], estimates["q2_est_ml_min"]])


def test_the_runout_keys_give_the_estimates_of_the_record_without_runout(records, tmp_path):
    paths, machine = records
    clean = _flowrates(paths["clean"], tmp_path / "clean")
    compensated = _flowrates(paths["runout"], tmp_path / "compensated", "--machine", str(machine))
    # uncompensated, the runout is more than the filter can explain: it says so (not trusted, exit 3)
    uncompensated = _flowrates(paths["runout"], tmp_path / "uncompensated", code=UNTRUSTED_EXIT_CODE)
    gap = np.abs(compensated - clean).max()
    off = np.abs(uncompensated - clean).max()
    print(f"compensated - clean {gap:.2e}, uncompensated - clean {off:.3f} ml/min")
    assert gap < 1e-4 * NOMINAL, gap  # the record's 5 decimals of um are all that differs
    assert off > 30 * gap, (off, gap)
    summary = (tmp_path / "compensated" / "summary.json").read_text()
    assert '"runout": "machine file [probes] runout_* keys"' in summary
    summary = json.loads((tmp_path / "uncompensated" / "summary.json").read_text())
    assert summary["model_mismatch"]["final"] != "consistent"


def test_runout_with_probes_not_along_the_estimator_s_axes_is_one_line(records, tmp_path, capsys):
    paths, machine = records
    code = main(
        ["estimate", str(paths["runout"]), "--out", str(tmp_path / "o"), "--no-progress", "--machine",
         str(machine), "--probe", "x1.angle_deg=30"]
    )  # fmt: skip
    assert code == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1
    assert "runout compensation needs the readings along the probes' axes" in error
