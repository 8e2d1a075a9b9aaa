"""A fixed parameter set after initialization: fmi2Error (FMI 2.0, section 4.2.4), not pythonfmu's fmi2Fatal.

The slave refuses the set and flags it to the FMU's loader (``oilwatch/cosim/native/fmi2_loader.c``), which
returns fmi2Error for that call only; the instance keeps its value and steps on. Checked on the toy plant
(built in a fresh process) through fmpy and through the Python-free C host (``tests/c_host/fmi2_host.c``).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import zipfile

import pytest
from fixtures.fmu_subprocess import run_json
from fmpy import read_model_description
from test_c_host import HOST_SOURCE, _clean_environment
from test_fmi_slave_behaviour import PRELUDE

REFUSAL = "noise_um is a fixed parameter: it can be set only before fmi2ExitInitializationMode; 3.0 was not"


def _fmpy_case(toys, logging_on: bool, late: str) -> dict:
    """Initialize the toy plant (noise 0), step, make the ``late`` call, step again; the statuses and log."""
    prelude = PRELUDE.replace("loggingOn=True", f"loggingOn={logging_on}")
    return run_json(
        prelude
        + f"""
plant, vr = load({str(toys / "ToyPlant.fmu")!r})
init(plant, vr, {{"noise_um": 0.0}})
plant.doStep(0.0, 1e-3)
before = plant.getReal([vr["y_um"]])[0]
try:
    {late}
    status = 0
except FMICallException as error:
    status = error.status
if status == 3:  # pythonfmu's wrapper released its references on the exception: the instance must outlive it
    import gc
    gc.collect()
try:
    plant.doStep(1e-3, 1e-3)
    step = 0
except FMICallException as error:
    step = error.status
after = plant.getReal([vr["y_um"], vr["y_true_um"]])
result = {{"status": status, "step": step, "noise_free": after[0] == after[1], "before": before,
           "log": LOG}}
"""
    )


@pytest.mark.parametrize("logging_on", [True, False])
def test_fmpy_sees_fmi2error_and_the_instance_steps_on(toys, logging_on):
    result = _fmpy_case(toys, logging_on, 'plant.setReal([vr["noise_um"]], [3.0])')
    assert result["status"] == 3  # fmi2Error
    assert result["step"] == 0  # the next fmi2DoStep works
    assert result["noise_free"]  # 3.0 was not applied: the output still has no noise
    errors = [message for status, message in result["log"] if status == 3]
    assert any(REFUSAL in message for message in errors), result["log"]  # logged even with logging off
    assert not [message for status, message in result["log"] if status == 4], result["log"]


def test_other_exceptions_in_a_set_stay_fatal(toys):
    """Only the refusal the slave flags is mapped: a set the slave fails on otherwise stays fmi2Fatal."""
    result = _fmpy_case(toys, True, "plant.setReal([987654], [3.0])")
    assert result["status"] == 4


def test_the_c_host_sees_fmi2error_and_runs_to_the_end(toys, tmp_path):
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    assert compiler, "the C host test needs the system's C compiler (cc)"
    host = tmp_path / "fmi2_host"
    subprocess.run([compiler, "-O2", "-Wall", "-o", str(host), str(HOST_SOURCE), "-ldl"], check=True)
    fmu = toys / "ToyPlant.fmu"
    md = read_model_description(str(fmu))
    folder = tmp_path / "plant"
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    base = [
        f"fmu plant {folder} {md.coSimulation.modelIdentifier} {md.guid}",
        f"real plant {vr['noise_um']} 0.0",
        f"output plant {vr['y_um']} y_um",
    ]
    outputs = {}
    for name, extra in (("plain", []), ("late", [f"late plant {vr['noise_um']} 3.0"])):
        spec, out = tmp_path / f"{name}.txt", tmp_path / f"{name}.csv"
        spec.write_text("\n".join([*base, *extra, "run 0.01 0.001"]) + "\n")
        process = subprocess.run(
            [str(host), str(spec), str(out)],
            env=_clean_environment(),
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert process.returncode == 0, process.stderr
        outputs[name] = (out.read_text(), process.stderr)
    text, log = outputs["late"]
    assert f"plant: fmi2SetReal of {vr['noise_um']} after initialization returned Error" in log
    assert any(line.startswith("[Error] plant") and REFUSAL in line for line in log.splitlines()), log
    assert "[Fatal]" not in log
    assert text == outputs["plain"][0]  # the refused value changed nothing: same rows, bit for bit
    assert len(text.splitlines()) == 11
