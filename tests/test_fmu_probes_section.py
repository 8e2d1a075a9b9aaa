"""Both FMUs read the machine file's ``[probes]``: the probes' mounting angle (one declaration in
``fmu_src/machine_parameters.py``) defaults to the machine file's layout in the plant and in the estimator,
the estimator's ``offset_prior_std_um = -1`` is, on the machine preset, the machine file's prior, and an
unreadable ``baseline_file`` is a one-line fmi2Error naming the parameter and the file, not fmi2Fatal.

The machine is the bundled turbine with ``layout = "api670"`` (45 deg) and a 7 um offset prior. Every FMU
runs in a fresh process."""

from __future__ import annotations

import math

import pytest
from fixtures.fmu_subprocess import REPO_ROOT, run_json
from test_ekf_fmu import FMPY_PRELUDE

NOMINAL = 596.3
COSIM_S = 1.0

BODY = """
import numpy as np
h = 1e-3
result = {}
api = {"machine_file": MACHINE}
# the plant: noise-free, one step; measured vs true positions
for name, strings in (("plant_api670", api), ("plant_bundled", {})):
    plant, pv = load(PLANT, name, {"noise_um": 0.0}, strings=strings)
    plant.doStep(0.0, h)
    result[name] = plant.getReal([pv[n] for n in ("x1_um", "y1_um", "x1_true_um", "y1_true_um")])
# the estimator's offset prior: -1 is the preset's; the machine preset's (the default) is the machine file's
# [probes] offset_prior_std_um, the paper preset's 0 keeps the offsets known
for name, reals, strings in (("prior_machine", {"offset_prior_std_um": -1.0}, {**api, "preset": "machine"}),
                             ("prior_bundled", {"offset_prior_std_um": -1.0}, {"preset": "machine"}),
                             ("prior_default", {}, api),
                             ("prior_paper", {}, {**api, "preset": "paper"})):
    ekf, ev = load(EKF, name, reals, strings=strings)
    result[name] = ekf.getReal([ev["offset_x1_std_um"]])[0]
# the estimator's angle: the machine file's layout by default, against an explicit 0 deg on the same record
# (the paper preset: offsets and unbalance known, so that 1 s shows the angle alone)
plant, pv = load(PLANT, "plant", {"noise_um": 1.0}, {"seed": 3}, api)
filters = {name: load(EKF, name, reals, strings={**api, "preset": "paper"})
           for name, reals in (("ekf_layout", {}), ("ekf_zero", {"probe_angle_deg": 0.0}))}
rows = cosimulate(plant, pv, filters, STEPS, ["nis"])
nis = {name: [row[0] for row in table] for name, table in rows.items()}
for name, (ekf, ev) in filters.items():
    result[name] = {"q": ekf.getReal([ev["q1_est_ml_min"], ev["q2_est_ml_min"]]),
                    "nis": float(np.mean(nis[name][len(nis[name]) // 2:]))}
# an unreadable baseline file
BAD.write_text("{not json")
try:
    load(EKF, "ekf_bad", strings={"baseline_file": str(BAD)})
    outcome = "initialized"
except FMICallException as error:
    outcome = [error.function, error.status]
result["bad_baseline"] = {"outcome": outcome, "log": [(s, m) for i, s, m in LOG if i == "ekf_bad"]}
"""


@pytest.fixture(scope="module")
def probes_run(built_fmus, tmp_path_factory):
    folder = tmp_path_factory.mktemp("api670_machine")
    text = (REPO_ROOT / "models" / "turbine.toml").read_text(encoding="utf-8")
    for old, new in (
        ('layout = "xy"', 'layout = "api670"'),
        ("offset_prior_std_um = 25.0", "offset_prior_std_um = 7.0"),
    ):
        assert old in text
        text = text.replace(old, new)
    (folder / "turbine.toml").write_text(text, encoding="utf-8")
    (folder / "tables").symlink_to(REPO_ROOT / "models" / "tables")
    head = (
        "from pathlib import Path\n"
        f"PLANT = {str(built_fmus / 'RotorBearingPlant.fmu')!r}\n"
        f"EKF = {str(built_fmus / 'OilFlowEKF.fmu')!r}\n"
        f"MACHINE = {str(folder / 'turbine.toml')!r}\nBAD = Path({str(folder / 'baseline.json')!r})\n"
        f"STEPS = {round(COSIM_S * 1000)}\n"
    )
    return run_json(FMPY_PRELUDE + head + BODY, timeout=600)


def test_the_plant_probe_angle_defaults_to_the_machine_file_layout(probes_run):
    x1, y1, x, y = probes_run["plant_api670"]
    c = s = math.cos(math.radians(45.0))
    assert abs(x) > 1.0 and abs(y) > 1.0  # the journal sits off the centre in both axes
    assert x1 == pytest.approx(c * x + s * y, abs=1e-9)
    assert y1 == pytest.approx(-s * x + c * y, abs=1e-9)
    x1, y1, x, y = probes_run["plant_bundled"]
    assert (x1, y1) == pytest.approx((x, y), abs=1e-12)  # the turbine's "xy" layout: 0 deg


def test_the_estimator_offset_prior_minus_one_is_the_machine_files(probes_run):
    assert probes_run["prior_machine"] == pytest.approx(7.0, rel=1e-9)
    assert probes_run["prior_bundled"] == pytest.approx(25.0, rel=1e-9)
    assert probes_run["prior_default"] == pytest.approx(7.0, rel=1e-9)  # the default is the machine preset
    assert probes_run["prior_paper"] == 0.0  # the paper preset: offsets known (the paper's calibrated probes)


def test_the_estimator_probe_angle_defaults_to_the_machine_file_layout(probes_run):
    layout, zero = probes_run["ekf_layout"], probes_run["ekf_zero"]
    # Measured when written (1 s, 1 um): the layout's filter -0.30 / +0.01 % of nominal, NIS 4.07; the 0 deg
    # filter reads the rotated positions as another journal position: -34 / -32 %, NIS 224.
    assert all(abs(q / NOMINAL - 1.0) < 0.01 for q in layout["q"]), layout
    assert layout["nis"] == pytest.approx(4.0, rel=0.25), layout
    assert max(abs(q / NOMINAL - 1.0) for q in zero["q"]) > 0.1 and zero["nis"] > 40.0, zero


def test_an_unreadable_baseline_file_is_fmi2error_with_one_line_naming_it(probes_run, tmp_path):
    bad = probes_run["bad_baseline"]
    assert bad["outcome"] == ["fmi2ExitInitializationMode", 3], bad  # fmi2Error, not fmi2Fatal (4)
    errors = [message for status, message in bad["log"] if status >= 3]
    assert len(errors) == 1, bad
    assert "baseline_file" in errors[0] and "baseline.json" in errors[0] and "\n" not in errors[0]
