"""Fast checks of the modules whose full tests need the built FMUs or long runs (those are marked slow): the
two FMU slaves' Python classes driven as pythonfmu would drive them, and their FMI 3.0 shells, without
building an FMU; the FMI 3.0 registry; the run plot; a short ``oilwatch estimate`` with its views and report;
``python -m oilwatch``. Together with the fast tests of each module they make the fast tier
(``python -m pytest -q -m "not slow"``) touch every module."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
from fixtures.fmu_subprocess import REPO_ROOT, run_json

from oilwatch.scenarios import make_run
from oilwatch.scenarios.plot import plot_estimates
from oilwatch.scenarios.summary import summarize


def test_both_slaves_initialize_step_and_refuse_a_fixed_parameter_after_initialization():
    """In a fresh process (the slave modules must not load into the pytest process): each slave declares
    a unit and a description for every variable, initializes with its defaults, steps 20 ms with finite
    outputs, and refuses a fixed parameter set after initialization, logging why at status error."""
    result = run_json(
        """
import math
from pythonfmu.enums import Fmi2Causality, Fmi2Status
from oilwatch.fmu_src.oilwatch_ekf_slave import OilFlowEKF
from oilwatch.fmu_src.oilwatch_plant_slave import RotorBearingPlant
result = {}
for cls, output in ((RotorBearingPlant, "x1_um"), (OilFlowEKF, "q1_est_ml_min")):
    slave = cls(instance_name="shell")
    slave.to_xml()
    vr = {v.name: v.value_reference for v in slave.vars.values()}
    undocumented = [v.name for v in slave.vars.values() if not v.description]
    unitless = [v.name for v in slave.vars.values() if type(v).__name__ == "UnitReal" and not v.unit]
    slave.setup_experiment(0.0, None, None)
    slave.enter_initialization_mode()
    slave.exit_initialization_mode()
    for k in range(20):
        slave.do_step(k * 1e-3, 1e-3)
    value = slave.get_real([vr[output]])[0]
    try:
        slave.set_real([vr["noise_um"]], [3.0])
        refused = None
    except Exception as error:
        refused = str(error)
    errors = [entry.msg for entry in slave.log_queue if entry.status == Fmi2Status.error]
    result[cls.__name__] = {"undocumented": undocumented, "unitless": unitless,
                            "finite": math.isfinite(value), "refused": refused, "errors": errors,
                            "noise_um": slave.noise_um}
"""
    )
    for name, outcome in result.items():
        assert outcome["undocumented"] == [] and outcome["unitless"] == [], name
        assert outcome["finite"], name
        assert "noise_um is a fixed parameter" in outcome["refused"], name
        assert any("noise_um is a fixed parameter" in message for message in outcome["errors"]), name
        assert outcome["noise_um"] != 3.0, name  # not applied


def test_the_run_plot_is_drawn_from_result_columns(tmp_path):
    run = make_run("sudden-drop", duration_s=20.0)
    time_s = np.round(np.arange(20001) * 1e-3, 9)
    true = np.where(time_s < 10.0, 596.3, 447.225)
    columns = {"time_s": time_s}
    for b in (1, 2):
        columns[f"q{b}_true_ml_min"], columns[f"q{b}_est_ml_min"] = true, true * 1.01
        columns[f"q{b}_std_ml_min"] = true * 0.005
        columns[f"starved{b}"] = (time_s >= 10.6).astype(float)
    path = plot_estimates(run, columns, summarize(run, columns), tmp_path / "estimates.png")
    assert path.stat().st_size > 10_000


def test_python_m_oilwatch_lists_the_commands():
    command = [sys.executable, "-m", "oilwatch", "--help"]
    process = subprocess.run(command, cwd=REPO_ROOT, capture_output=True, text=True, timeout=60)
    assert process.returncode == 0 and "run" in process.stdout and "study" in process.stdout


def test_the_fmi3_shells_mirror_the_fmi2_slaves_and_step():
    """In a fresh process, without building: each FMI 3.0 shell registers the FMI 2.0 slave's variables in
    the same order (value references), with the same units and ranges, plus ``time`` last; it initializes
    with the defaults and steps with finite outputs."""
    result = run_json(
        """
import math
from oilwatch.fmu_src.oilwatch_ekf_fmi3_slave import OilFlowEKF
from oilwatch.fmu_src.oilwatch_plant_fmi3_slave import RotorBearingPlant
result = {}
for cls, output in ((RotorBearingPlant, "x1_um"), (OilFlowEKF, "q1_est_ml_min")):
    shell = cls(instance_name="shell")
    shell.to_xml()
    fmi2 = [(v.name, getattr(v, "unit", None), v.minimum if hasattr(v, "minimum") else None,
             v.maximum if hasattr(v, "maximum") else None) for v in shell.slave.declared_variables]
    fmi3 = [(v.name, getattr(v, "unit", None), getattr(v, "minimum", None), getattr(v, "maximum", None))
            for v in shell.vars.values()]
    shell.setup_experiment(0.0)
    shell.enter_initialization_mode()
    shell.exit_initialization_mode()
    for k in range(10):
        shell.do_step(k * 1e-3, 1e-3)
    result[cls.__name__] = {"same": fmi3[:-1] == fmi2, "last": fmi3[-1][0],
                            "references": [v.value_reference for v in shell.vars.values()],
                            "finite": math.isfinite(getattr(shell.slave, output))}
"""
    )
    for name, outcome in result.items():
        assert outcome["same"] and outcome["last"] == "time", name
        assert outcome["references"] == sorted(outcome["references"]), name
        assert outcome["finite"], name


def test_the_fmi3_registry_is_the_fmi2_registry_with_its_shell_scripts():
    from oilwatch.cosim.fmi3_build import FMI3_REGISTRY
    from oilwatch.cosim.fmu_build import REGISTRY, package_root

    assert [e.name for e in FMI3_REGISTRY] == [e.name for e in REGISTRY]
    for fmi3, fmi2 in zip(FMI3_REGISTRY, REGISTRY, strict=True):
        assert (fmi3.fmi2_script, fmi3.data_globs) == (fmi2.script, fmi2.data_globs)
        assert (package_root() / fmi3.script).is_file()


def test_an_estimate_of_a_short_record_writes_the_views_and_a_self_contained_report(tmp_path, monkeypatch):
    """``oilwatch estimate`` on 1 s of the in-process plant at nominal flow (CSV, um): four view PNGs and
    report.html with them embedded, both bearings healthy (the full checks are slow: test_estimate_cli).
    The run reads the machine file once and builds the rotor-bearing system once (the process's model
    cache emptied first)."""
    import json

    from fixtures.plant_records import plant_run

    from oilwatch.cli import main
    from oilwatch.models import machine as machine_module
    from oilwatch.models.system import factory
    from oilwatch.monitoring import estimator_setup
    from oilwatch.records.writers import write_record

    t, _, measured, _ = plant_run(1.0, 1e-3, 1.0)
    columns = {
        "time_s": t,
        **{f"{n}_um": measured[:, i] * 1e6 for i, n in enumerate(("x1", "y1", "x2", "y2"))},
    }
    record = write_record(tmp_path / "nominal.csv", columns)
    monkeypatch.setattr(estimator_setup, "_MODELS", {})
    monkeypatch.setattr(estimator_setup, "_REDUCED", {})
    calls = {machine_module.load_machine.__code__: 0, factory.build_system.__code__: 0}

    def count(frame, event, arg):
        if event == "call" and frame.f_code in calls:
            calls[frame.f_code] += 1

    sys.setprofile(count)
    try:
        status = main(["estimate", str(record), "--out", str(tmp_path / "out"), "--no-progress"])
    finally:
        sys.setprofile(None)
    assert status == 0
    assert list(calls.values()) == [1, 1]  # load_machine, build_system
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert set(summary["views"]) == {"trend", "centerline", "orbits", "probe_health"}
    page = (tmp_path / "out" / "report.html").read_text()
    assert page.count("data:image/png;base64,") == 4 and "<script" not in page
    assert all(summary["verdict"][f"bearing{b}"].startswith("healthy") for b in (1, 2)), summary["verdict"]
