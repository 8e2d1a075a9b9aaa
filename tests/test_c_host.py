"""Both FMI 2.0 FMUs in a host with no Python in it: tests/c_host/fmi2_host.c, compiled here with cc.

The host runs the plant and the estimator coupled (2 s at 1 ms) in a process started without
``LD_PRELOAD``, ``PYTHON*`` or ``OILWATCH_PYTHON*`` variables: the FMUs' own loader
(``oilwatch/cosim/native/fmi2_loader.c``) must find the build environment from
``resources/oilwatch_python.txt`` and libpython from that environment's ``pyvenv.cfg``. Its outputs must
equal fmpy's for the same parameters: the plant's measured signals bit for bit (same seed), the
estimator's estimates within 1e-9 relative when fmpy feeds it the plant outputs the C host recorded. The
host exits 0 only after freeing both instances and unloading both libraries. A wrong environment must give
fmi2Instantiate NULL and one logged message naming it and ``OILWATCH_PYTHON_ENV``, never a crash. The
coupled run also times the estimator's steps (the host's ``timing`` directive, used by
benchmarks/ekf_fmu_c_host.py) and reads one Boolean output: the comparison with fmpy covers the host with
both in use.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fixtures.fmu_subprocess import run_json
from fmpy import read_model_description

HOST_SOURCE = Path(__file__).parent / "c_host" / "fmi2_host.c"
STOP, STEP = 2.0, 1e-3
PLANT_PARAMETERS = {
    "seed": 7,
    "noise_um": 1.0,
    "q1_final_ml_min": 0.8 * 596.3,
    "q2_final_ml_min": 0.9 * 596.3,
    "fault_time_s": 1.0,
    "fault_duration_s": 0.1,
}
EKF_PARAMETERS = {"noise_um": 1.0}
PLANT_OUTPUTS = ["x1_um", "y1_um", "x2_um", "y2_um", "t_sample_s", "q1_ml_min", "q2_ml_min"]
CONNECTED = ["x1_um", "y1_um", "x2_um", "y2_um", "t_sample_s"]
EKF_OUTPUTS = ["q1_est_ml_min", "q2_est_ml_min", "q1_std_ml_min", "q2_std_ml_min", "nis"]
EKF_FLAGS = ["converged"]


def _clean_environment(**extra) -> dict[str, str]:
    """The test's environment without anything that would hand the FMU a Python."""
    dropped = ("PYTHON", "LD_PRELOAD", "LD_LIBRARY_PATH", "OILWATCH_PYTHON", "VIRTUAL_ENV")
    env = {k: v for k, v in os.environ.items() if not k.startswith(dropped)}
    env.update(OPENBLAS_NUM_THREADS="1", **extra)
    return env


@pytest.fixture(scope="module")
def host(tmp_path_factory) -> Path:
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    assert compiler, "the C host test needs the system's C compiler (cc)"
    binary = tmp_path_factory.mktemp("c_host") / "fmi2_host"
    subprocess.run([compiler, "-O2", "-Wall", "-o", str(binary), str(HOST_SOURCE), "-ldl"], check=True)
    return binary


class HostFmu:
    """One FMU extracted for the C host, with its variables by name."""

    def __init__(self, fmu: Path, folder: Path, instance: str):
        self.path, self.folder, self.instance = fmu, folder, instance
        with zipfile.ZipFile(fmu) as archive:
            archive.extractall(folder)
        self.md = read_model_description(str(fmu))
        self.variables = {v.name: v for v in self.md.modelVariables}

    def spec(self, parameters: dict) -> list[str]:
        lines = [f"fmu {self.instance} {self.folder} {self.md.coSimulation.modelIdentifier} {self.md.guid}"]
        for name, value in parameters.items():
            variable = self.variables[name]
            kind = {"Real": "real", "Integer": "integer"}[variable.type]
            lines.append(f"{kind} {self.instance} {variable.valueReference} {value!r}")
        return lines

    def vr(self, name: str) -> int:
        return self.variables[name].valueReference


@pytest.fixture(scope="module")
def fmus(built_fmus, tmp_path_factory):
    root = tmp_path_factory.mktemp("c_host_fmus")
    return (
        HostFmu(built_fmus / "RotorBearingPlant.fmu", root / "plant", "plant"),
        HostFmu(built_fmus / "OilFlowEKF.fmu", root / "ekf", "ekf"),
    )


def _run_host(host: Path, spec: list[str], folder: Path, env: dict, timeout: float = 600.0):
    spec_file, out = folder / "spec.txt", folder / "out.csv"
    spec_file.write_text("\n".join(spec) + "\n")
    process = subprocess.run(
        [str(host), str(spec_file), str(out)], env=env, capture_output=True, text=True, timeout=timeout
    )
    return process, out


@pytest.fixture(scope="module")
def coupled(host, fmus, tmp_path_factory):
    plant, ekf = fmus
    spec = plant.spec(PLANT_PARAMETERS) + ekf.spec(EKF_PARAMETERS)
    spec += [f"connect plant {plant.vr(n)} ekf {ekf.vr(n)}" for n in CONNECTED]
    spec += [f"output plant {plant.vr(n)} {n}" for n in PLANT_OUTPUTS]
    spec += [f"output ekf {ekf.vr(n)} {n}" for n in EKF_OUTPUTS]
    spec += [f"boolean ekf {ekf.vr(n)} {n}" for n in EKF_FLAGS]
    folder = tmp_path_factory.mktemp("c_host_run")
    spec += [f"timing ekf {folder / 'timing.csv'}", f"run {STOP!r} {STEP!r}"]
    process, out = _run_host(host, spec, folder, _clean_environment())
    print(process.stderr)
    return process, out


def test_the_timing_directive_writes_one_positive_record_per_step(coupled):
    process, out = coupled
    assert process.returncode == 0, process.stderr
    timing = np.genfromtxt(out.parent / "timing.csv", delimiter=",", names=True, dtype=np.int64)
    assert list(timing.dtype.names) == ["step", "cpu_ns", "wall_ns"]
    assert np.array_equal(timing["step"], np.arange(round(STOP / STEP)))
    assert np.all(timing["cpu_ns"] > 0) and np.all(timing["wall_ns"] > 0)
    flags = np.genfromtxt(out, delimiter=",", names=True)["converged"]
    assert set(np.unique(flags)) <= {0.0, 1.0}


def test_c_host_runs_both_fmus_without_python_and_exits_cleanly(coupled):
    process, out = coupled
    assert process.returncode == 0, process.stderr
    assert "no Python in this process before loading the FMUs" in process.stderr
    assert "freed 2 instances, unloaded 2 libraries" in process.stderr
    data = np.genfromtxt(out, delimiter=",", names=True)
    assert len(data) == round(STOP / STEP)
    assert np.all(np.isfinite(data["q1_est_ml_min"]))


REFERENCE = """
import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

def load(path, instance, parameters):
    md = read_model_description(path)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), instanceName=instance,
                    modelIdentifier=md.coSimulation.modelIdentifier)
    variables = {{v.name: v for v in md.modelVariables}}
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0, stopTime={stop!r})
    for name, value in parameters.items():
        v = variables[name]
        (fmu.setReal if v.type == "Real" else fmu.setInteger)([v.valueReference], [value])
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    return fmu, {{n: v.valueReference for n, v in variables.items()}}

steps = round({stop!r} / {step!r})
plant, pvr = load({plant!r}, "plant", {plant_parameters!r})
plant_rows = []
for k in range(steps):
    plant.doStep(k * {step!r}, {step!r})
    plant_rows.append(plant.getReal([pvr[n] for n in {plant_outputs!r}]))
plant.terminate()
plant.freeInstance()

recorded = np.genfromtxt({csv!r}, delimiter=",", names=True)
ekf, evr = load({ekf!r}, "ekf", {ekf_parameters!r})
ekf_rows = []
for k in range(steps):
    ekf.setReal([evr[n] for n in {connected!r}], [float(recorded[n][k]) for n in {connected!r}])
    ekf.doStep(k * {step!r}, {step!r})
    ekf_rows.append(ekf.getReal([evr[n] for n in {ekf_outputs!r}]))
ekf.terminate()
ekf.freeInstance()
result = {{"plant": plant_rows, "ekf": ekf_rows}}
"""


def test_c_host_outputs_equal_fmpy_outputs(coupled, fmus):
    process, out = coupled
    assert process.returncode == 0, process.stderr
    plant, ekf = fmus
    reference = run_json(
        REFERENCE.format(
            stop=STOP,
            step=STEP,
            plant=str(plant.path),
            ekf=str(ekf.path),
            plant_parameters=PLANT_PARAMETERS,
            ekf_parameters=EKF_PARAMETERS,
            plant_outputs=PLANT_OUTPUTS,
            ekf_outputs=EKF_OUTPUTS,
            connected=CONNECTED,
            csv=str(out),
        ),
        timeout=900,
    )
    data = np.genfromtxt(out, delimiter=",", names=True)
    fmpy_plant = np.array(reference["plant"])
    for column, name in enumerate(PLANT_OUTPUTS):
        # %.17g round-trips every double: equality here is bit-identity
        assert np.array_equal(data[name], fmpy_plant[:, column]), name
    fmpy_ekf = np.array(reference["ekf"])
    for column, name in enumerate(EKF_OUTPUTS):
        np.testing.assert_allclose(data[name], fmpy_ekf[:, column], rtol=1e-9, atol=0.0, err_msg=name)
    # the drop happened inside the run: the comparison covers a changing flow, not a constant
    assert data["q1_ml_min"][-1] < 0.85 * 596.3


def _run_plant_briefly(host, plant, folder, **environment):
    spec = [*plant.spec({}), f"run {STEP!r} {STEP!r}"]
    process, _ = _run_host(host, spec, folder, _clean_environment(**environment), timeout=120)
    return process


def _fake_venv(folder: Path, home: str, version: str) -> Path:
    """A folder with only a pyvenv.cfg naming ``home`` (the base Python's bin folder) and ``version``."""
    folder.mkdir()
    (folder / "pyvenv.cfg").write_text(
        f"home = {home}\ninclude-system-site-packages = false\nversion = {version}\n"
    )
    return folder


@pytest.mark.parametrize(
    "setup, expected",
    [
        (
            lambda tmp: "/nonexistent/venv",
            "the Python environment '/nonexistent/venv' (OILWATCH_PYTHON_ENV) does",
        ),
        (
            lambda tmp: str(_fake_venv(tmp / "v", "/nonexistent/bin", "3.12.1")),
            "has no shared runtime library",
        ),
        (
            lambda tmp: str(_fake_venv(tmp / "v", "/usr/bin", "3.9.2")),
            "oilwatch FMUs need Python 3.10 or newer",
        ),
        (lambda tmp: str(tmp), "is neither a virtual environment (no pyvenv.cfg) nor a Python 3.10"),
    ],
    ids=["missing", "no-libpython", "old-python", "not-an-environment"],
)
def test_a_wrong_python_environment_gives_one_logged_line_and_no_crash(host, fmus, tmp_path, setup, expected):
    process = _run_plant_briefly(host, fmus[0], tmp_path, OILWATCH_PYTHON_ENV=setup(tmp_path))
    assert process.returncode == 4, process.stderr  # fmi2Instantiate returned NULL; teardown ran
    logged = [line for line in process.stderr.splitlines() if line.startswith("[Error] plant logStatusError")]
    assert len(logged) == 1, process.stderr
    assert expected in logged[0]
    assert "OILWATCH_PYTHON_ENV" in logged[0]  # the message says how to point elsewhere
    assert "freed 0 instances, unloaded 1 libraries" in process.stderr


def test_an_environment_without_numpy_gives_a_logged_error(host, fmus, tmp_path):
    empty = tmp_path / "empty_env"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(empty)], check=True)
    process = _run_plant_briefly(host, fmus[0], tmp_path, OILWATCH_PYTHON_ENV=str(empty))
    assert process.returncode == 4, process.stderr
    logged = [line for line in process.stderr.splitlines() if line.startswith("[Error] plant logStatusError")]
    assert len(logged) == 1, process.stderr
    assert "cannot import numpy (ModuleNotFoundError" in logged[0]
    assert str(empty) in logged[0] and "OILWATCH_PYTHON_ENV" in logged[0]
