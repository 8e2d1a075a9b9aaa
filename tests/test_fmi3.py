"""The FMI 3.0 twins of both FMUs (pythonfmu3, fmu_src/fmi3_shell.py) against the FMI 2.0 reference.

Same variables (names, value references, causality, variability, units, ranges, starts, descriptions),
same unit definitions and documentation; state get/set/serialize through fmpy.fmi3; the sudden-drop scenario
through oilwatch's master with the FMI 3.0 SSP gives the FMI 2.0 SSP's results for the same seed; the FMI 3.0
SSP loads; a refused input (a bad parameter, a fixed parameter set after initialization) is fmi3Error, as
in FMI 2.0, not pythonfmu3's fmi3Fatal; a fresh unpack in plain fmpy compiles none of the kernels (the build
shipped them) and the process exits cleanly. Runs happen in fresh subprocesses (the FMUs share the host
interpreter).
"""

from __future__ import annotations

import subprocess
import sys
import zipfile

import pytest
from fixtures.fmu_subprocess import assert_shipped_kernels_loaded_and_none_compiled, run_json
from fixtures.venvs import clean_env
from fmpy import read_model_description

NAMES = ("RotorBearingPlant", "OilFlowEKF")
FMI3_TYPE = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}


def _number(text):
    """A start/min/max attribute as a number (FMI 2.0 writes 75.0 where FMI 3.0 writes 75), text otherwise."""
    try:
        return float(text)
    except (TypeError, ValueError):
        return text


def _variables(md):
    return [
        (
            v.name,
            v.valueReference,
            v.causality,
            v.variability,
            v.unit,
            v.description,
            *map(_number, (v.start, v.min, v.max)),
        )
        for v in md.modelVariables
        if v.causality != "independent"
    ]


@pytest.mark.parametrize("name", NAMES)
def test_fmi3_fmu_declares_the_fmi2_variables_units_and_documentation(built_fmus, built_fmi3_fmus, name):
    fmi2 = read_model_description(str(built_fmus / f"{name}.fmu"))
    fmi3 = read_model_description(str(built_fmi3_fmus / f"{name}.fmu"))
    assert (fmi2.fmiVersion, fmi3.fmiVersion) == ("2.0", "3.0")
    assert _variables(fmi3) == _variables(fmi2)
    types = {v.name: v.type for v in fmi3.modelVariables}
    assert all(types[v.name] == FMI3_TYPE[v.type] for v in fmi2.modelVariables)
    assert [v.name for v in fmi3.modelVariables if v.causality == "independent"] == ["time"]
    units = {
        u.name: (u.baseUnit.factor, u.baseUnit.m, u.baseUnit.s, u.baseUnit.kg) for u in fmi2.unitDefinitions
    }
    units3 = {
        u.name: (u.baseUnit.factor, u.baseUnit.m, u.baseUnit.s, u.baseUnit.kg) for u in fmi3.unitDefinitions
    }
    assert units.items() <= units3.items()
    assert (fmi3.description, fmi3.author) == (fmi2.description, fmi2.author)
    experiment, reference = fmi3.defaultExperiment, fmi2.defaultExperiment
    assert [float(getattr(experiment, k)) for k in ("startTime", "stopTime", "stepSize")] == [
        float(getattr(reference, k)) for k in ("startTime", "stopTime", "stepSize")
    ]
    assert fmi3.coSimulation.canGetAndSetFMUstate and fmi3.coSimulation.canSerializeFMUstate
    with zipfile.ZipFile(built_fmi3_fmus / f"{name}.fmu") as archive:
        page = archive.read("documentation/index.html").decode()
    assert all(v.name in page for v in fmi2.modelVariables)


STATE = """
from fmpy import extract, read_model_description
from fmpy.fmi3 import FMU3Slave
path = {path!r}
md = read_model_description(path)
vr = {{v.name: v.valueReference for v in md.modelVariables}}
fmu = FMU3Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier,
                instanceName="x")
fmu.instantiate()
fmu.enterInitializationMode(startTime=0.0)
{set_parameters}
fmu.exitInitializationMode()
outputs = [vr[n] for n in {outputs!r}]
inputs = [vr[n] for n in {inputs!r}]

def steps(k0, n):
    rows = []
    for k in range(k0, k0 + n):
        if inputs:
            fmu.setFloat64(inputs, [1.0 + 0.01 * k, -2.0, 0.5, 3.0, k * 1e-3][: len(inputs)])
        fmu.doStep(k * 1e-3, 1e-3)
        rows.append(fmu.getFloat64(outputs))
    return rows

steps(0, 20)
state = fmu.getFMUState()
blob = fmu.serializeFMUState(state)
first = steps(20, 10)
fmu.setFMUState(state)
again = steps(20, 10)
restored = fmu.deserializeFMUState(blob)
fmu.setFMUState(restored)
from_bytes = steps(20, 10)
fmu.freeFMUState(state)
fmu.freeFMUState(restored)
fmu.terminate()
fmu.freeInstance()
result = {{"first": first, "again": again, "from_bytes": from_bytes, "size": len(blob)}}
"""


@pytest.mark.parametrize(
    "name, set_parameters, outputs, inputs",
    [
        ("RotorBearingPlant", "fmu.setInt32([vr['seed']], [5])", ["x1_um", "y2_um", "q1_ml_min"], []),
        (
            "OilFlowEKF",
            "",
            ["q1_est_ml_min", "q2_est_ml_min", "q1_std_ml_min", "nis"],
            ["x1_um", "y1_um", "x2_um", "y2_um", "t_sample_s"],
        ),
    ],
)
def test_fmi3_state_get_set_and_serialize_restore_the_run(
    built_fmi3_fmus, name, set_parameters, outputs, inputs
):
    result = run_json(
        STATE.format(
            path=str(built_fmi3_fmus / f"{name}.fmu"),
            set_parameters=set_parameters,
            outputs=outputs,
            inputs=inputs,
        ),
        timeout=300,
    )
    assert result["size"] > 0
    assert result["again"] == result["first"]
    assert result["from_bytes"] == result["first"]


START_UP_HEAVY = ("scipy.optimize", "scipy.interpolate", "scipy.special")
"""scipy packages whose import (0.15-0.2 s each, with what they import) an FMU's start does without."""
FRESH_UNPACK = f"""
import sys, tempfile
HEAVY = {START_UP_HEAVY!r}
from fmpy import extract, read_model_description
from fmpy.fmi3 import FMU3Slave
path = sys.argv[1]
md = read_model_description(path)
fmu = FMU3Slave(guid=md.guid, unzipDirectory=extract(path, tempfile.mkdtemp(dir=sys.argv[2])),
                modelIdentifier=md.coSimulation.modelIdentifier, instanceName="x")
fmu.instantiate()
fmu.enterInitializationMode(startTime=0.0)
fmu.exitInitializationMode()
print("@@heavy", sorted(m for m in HEAVY if m in sys.modules))
for k in range(50):
    fmu.doStep(k * 1e-3, 1e-3)
fmu.terminate()
fmu.freeInstance()
print("@@done")
"""


@pytest.mark.parametrize("name", NAMES)
def test_a_fresh_unpack_in_plain_fmpy_loads_the_shipped_kernels_compiles_none_and_exits_cleanly(
    built_fmi3_fmus, name, tmp_path
):
    """numba's cache log says what each kernel did: "data loaded" from the shipped files, "data saved" after
    compiling it here. The host exits normally (no os._exit): the FMU's layer mends pythonfmu3's teardown.
    Initialization imports none of :data:`START_UP_HEAVY`."""
    env = clean_env(NUMBA_DEBUG_CACHE="1", OPENBLAS_NUM_THREADS="1", TMPDIR=str(tmp_path))
    process = subprocess.run(
        [sys.executable, "-c", FRESH_UNPACK, str(built_fmi3_fmus / f"{name}.fmu"), str(tmp_path)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert_shipped_kernels_loaded_and_none_compiled(process)
    assert "@@heavy []" in process.stdout, [line for line in process.stdout.splitlines() if "@@heavy" in line]


SCENARIO = """
import numpy as np
from pathlib import Path
from oilwatch.scenarios import make_run
from oilwatch.scenarios.runner import read_result, run_scenario
columns = {{}}
for label, ssp in (("fmi2", {fmi2!r}), ("fmi3", {fmi3!r})):
    out = Path({out!r}) / label
    run_scenario(make_run("sudden-drop", duration_s={duration}, seed=4), out, ssp=Path(ssp), progress=False,
                 plot=False)
    columns[label] = read_result(out / "result.csv")
fmi2, fmi3 = columns["fmi2"], columns["fmi3"]
relative = {{}}
for name in fmi2:
    a, b = np.asarray(fmi2[name], float), np.asarray(fmi3[name], float)
    scale = np.maximum(np.abs(a), np.abs(b))
    relative[name] = float(np.max(np.abs(a - b) / np.where(scale > 0, scale, 1.0)))
result = {{"names": [sorted(fmi2), sorted(fmi3)], "rows": [len(fmi2["time_s"]), len(fmi3["time_s"])],
          "relative": relative, "q1_true_end": float(fmi2["q1_true_ml_min"][-1])}}
"""


def test_sudden_drop_through_the_master_with_the_fmi3_ssp_equals_the_fmi2_ssp(
    built_fmus, built_fmi3_fmus, tmp_path
):
    result = run_json(
        SCENARIO.format(
            fmi2=str(built_fmus / "OilStarvation.ssp"),
            fmi3=str(built_fmi3_fmus / "OilStarvation.ssp"),
            out=str(tmp_path),
            duration=4.0,
        ),
        timeout=900,
    )
    assert result["names"][0] == result["names"][1]
    assert result["rows"][0] == result["rows"][1] >= 4000
    assert max(result["relative"].values()) <= 1e-9, result["relative"]
    assert result["q1_true_end"] < 0.8 * 596.3  # the drop is inside the compared record


def test_fmi3_ssp_loads_with_its_bindings_and_connections(built_fmus, built_fmi3_fmus):
    result = run_json(
        f"""
from oilwatch.cosim.fmi3_loading import Slave3
from oilwatch.cosim.ssp import master_from_ssp, open_ssp
summary = {{}}
for label, path in (("fmi2", {str(built_fmus / "OilStarvation.ssp")!r}),
                    ("fmi3", {str(built_fmi3_fmus / "OilStarvation.ssp")!r})):
    with open_ssp(path) as system:
        summary[label] = {{"parameters": {{s.name: s.parameters for s in system.fmus}},
                          "connections": sorted(str(c) for c in system.connections)}}
    with master_from_ssp(path) as master:
        summary[label]["kinds"] = sorted(type(s).__name__ for s in master.slaves.values())
result = summary
"""
    )
    assert result["fmi3"]["parameters"] == result["fmi2"]["parameters"]
    assert result["fmi3"]["connections"] == result["fmi2"]["connections"]
    assert len(result["fmi3"]["connections"]) == 6  # four probes, the sample time, the keyphasor
    assert result["fmi3"]["kinds"] == ["Slave3", "Slave3"]
    assert result["fmi2"]["kinds"] == ["Slave", "Slave"]


REFUSALS = """
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave
LOG = []

def log(environment, status, category, message):
    LOG.append((int(status), message.decode()))

def load(path, name):
    md = read_model_description(path)
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=extract(path),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    fmu.instantiate(loggingOn=True, logMessage=log)
    fmu.enterInitializationMode(startTime=0.0)
    return fmu, {v.name: v.valueReference for v in md.modelVariables}

def status_of(call):
    try:
        call()
        return 0
    except FMICallException as error:
        return int(error.status)

result = {}
ekf, ev = load(EKF, "ekf_bad")
ekf.setFloat64([ev["q_std_velocity_um_s"]], [-5.0])  # neither >= 0 nor -1: refused at initialization
result["bad_parameter"] = status_of(ekf.exitInitializationMode)
result["bad_parameter_log"], LOG[:] = list(LOG), []
plant, pv = load(PLANT, "plant")
plant.setFloat64([pv["noise_um"]], [0.0])
plant.exitInitializationMode()
plant.doStep(0.0, 1e-3)
result["late_fixed"] = status_of(lambda: plant.setFloat64([pv["noise_um"]], [3.0]))
result["late_fixed_log"] = list(LOG)
# the wrapper released its references on the refusal's exception (fmu_src/slave_base.py): the instance must
# outlive a garbage collection, step on and free cleanly
import gc
gc.collect()
result["step_after"] = status_of(lambda: plant.doStep(1e-3, 1e-3))
y, y_true = plant.getFloat64([pv["x1_um"], pv["x1_true_um"]])
result["noise_free"] = y == y_true
plant.terminate()
plant.freeInstance()
ekf.freeInstance()
gc.collect()
"""

INTERNAL = """
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave
md = read_model_description(PLANT)
plant = FMU3Slave(guid=md.guid, unzipDirectory=extract(PLANT),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="plant")
plant.instantiate()
plant.enterInitializationMode(startTime=0.0)
plant.exitInitializationMode()
try:
    plant.setFloat64([987654], [1.0])  # no such variable: an internal error, not the user's input
    result = 0
except FMICallException as error:
    result = int(error.status)
"""


def test_fmi3_user_errors_are_fmi3error_with_one_line_and_internal_errors_stay_fatal(built_fmi3_fmus):
    head = (
        f"EKF = {str(built_fmi3_fmus / 'OilFlowEKF.fmu')!r}\n"
        f"PLANT = {str(built_fmi3_fmus / 'RotorBearingPlant.fmu')!r}\n"
    )
    result = run_json(head + REFUSALS, timeout=300)
    fmi3_error, fmi3_fatal = 3, 4
    assert result["bad_parameter"] == fmi3_error, result
    errors = [m for s, m in result["bad_parameter_log"] if s == fmi3_error]
    assert any("q_std_velocity_um_s must lie in [-1, 1e+06] um/s, got -5" in m for m in errors), result
    assert not [m for s, m in result["bad_parameter_log"] if s == fmi3_fatal], result
    # a fixed parameter after initialization: refused, not applied, and the instance steps on
    assert result["late_fixed"] == fmi3_error, result
    message = "noise_um is a fixed parameter: it can be set only before fmi3ExitInitializationMode"
    assert any(message in m for s, m in result["late_fixed_log"] if s == fmi3_error), result
    assert result["step_after"] == 0 and result["noise_free"], result
    assert run_json(head + INTERNAL, timeout=300) == fmi3_fatal
