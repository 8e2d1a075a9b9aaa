"""pythonfmu slaves built on fmu_src.slave_base, driven through fmpy in fresh processes:
state save/restore, parameter errors at initialization, failures in do_step, two FMUs at once."""

from __future__ import annotations

import pytest
from fixtures.fmu_subprocess import edited_archive, run_json

PRELUDE = """
from ctypes import byref
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (FMU2Slave, calloc, free, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE,
                       fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE)
from fmpy.logging import addLoggerProxy

LOG = []

def _logger(env, instance, status, category, message):
    LOG.append((status, message.decode()))

CALLBACKS = fmi2CallbackFunctions()
CALLBACKS.logger = fmi2CallbackLoggerTYPE(_logger)
CALLBACKS.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
CALLBACKS.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
addLoggerProxy(byref(CALLBACKS))

def load(path, name="inst"):
    md = read_model_description(path)
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(path),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    slave.instantiate(callbacks=CALLBACKS, loggingOn=True)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    return slave, vr

def init(slave, vr, reals=None, integers=None):
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    for name, value in (reals or {}).items():
        slave.setReal([vr[name]], [value])
    for name, value in (integers or {}).items():
        slave.setInteger([vr[name]], [value])
    slave.exitInitializationMode()
"""


def test_state_restore_is_bit_identical_including_rng_and_arrays(toys):
    result = run_json(
        PRELUDE
        + """
plant, vr = load({plant!r})
init(plant, vr, {{"noise_um": 1.0}}, {{"seed": 7}})
h = 1e-3
out = [vr["y_um"], vr["sum_um"]]
for k in range(500):
    plant.doStep(k * h, h)
state = plant.getFMUstate()

def run_from_500():
    rows = []
    for k in range(500, 700):
        plant.doStep(k * h, h)
        rows.append(plant.getReal(out))
    return rows

first = run_from_500()
plant.setFMUstate(state)
second = run_from_500()
plant.setFMUstate(state)
third = run_from_500()
serialized = plant.serializeFMUstate(state)
restored = plant.deSerializeFMUstate(serialized)
plant.setFMUstate(restored)
fourth = run_from_500()
plant.freeFMUstate(state)
plant.terminate()
plant.freeInstance()
result = {{"first": first, "second": second, "third": third, "fourth": fourth}}
""".format(plant=str(toys / "ToyPlant.fmu"))
    )
    assert result["first"] == result["second"] == result["third"] == result["fourth"]
    # The noise is really random and the array state really advances.
    ys = [row[0] for row in result["first"]]
    assert len(set(ys)) == len(ys)


@pytest.mark.parametrize(
    ("reals", "name"),
    [
        ('{"width_s": -1.0}', "width_s"),
        ('{"noise_um": float("nan")}', "noise_um"),
        ('{"y0_um": 30.0}', "y1_um"),
    ],
)
def test_bad_parameter_fails_initialization_with_its_name_and_the_host_survives(toys, reals, name):
    result = run_json(
        PRELUDE
        + """
plant, vr = load({plant!r})
try:
    init(plant, vr, {reals})
    outcome = "initialized"
except FMICallException as error:
    outcome = [error.function, error.status]
plant.freeInstance()
result = {{"outcome": outcome, "log": LOG}}
""".format(plant=str(toys / "ToyPlant.fmu"), reals=reals)
    )
    # fmi2Error, not pythonfmu's fmi2Fatal: the user's input was refused, no instance is corrupted
    assert result["outcome"] == ["fmi2ExitInitializationMode", 3]
    errors = [message for status, message in result["log"] if status == 3]
    assert not [message for status, message in result["log"] if status == 4], result
    assert any(name in message and message.startswith("inst: ") for message in errors), result
    # The message states the allowed range or rule, not just the name.
    assert any(("must" in m) for m in errors)


def test_exception_in_do_step_is_reported_not_crashing(toys):
    result = run_json(
        PRELUDE
        + """
plant, vr = load({plant!r})
init(plant, vr, {{"y0_um": -2e6}})
try:
    plant.doStep(0.0, 1e-3)
    outcome = "stepped"
except FMICallException as error:
    outcome = [error.function, error.status]
result = {{"outcome": outcome, "log": LOG}}
""".format(plant=str(toys / "ToyPlant.fmu"))
    )
    assert result["outcome"] == ["fmi2DoStep", 4]
    # the slave's message verbatim: a '%' in it is text, not a printf conversion
    message = "toy failure requested by y0_um (100 % sure, 3 %d, %s)"
    assert any(message in m for s, m in result["log"] if s == 3)


def test_two_fmus_in_one_process_share_the_first_ones_oilwatch(toys):
    result = run_json(
        """
import sys
from fmpy import simulate_fmu
simulate_fmu({plant!r}, stop_time=0.01, output_interval=1e-3)
first = sys.modules["oilwatch.fmu_src.slave_base"].__file__
rows = simulate_fmu({filt!r}, stop_time=0.01, output_interval=1e-3, start_values={{"alpha": 0.05}})
result = {{"first": first, "second": sys.modules["oilwatch.fmu_src.slave_base"].__file__,
          "cosim_loaded": "oilwatch.cosim" in sys.modules, "rows": len(rows)}}
""".format(plant=str(toys / "ToyPlant.fmu"), filt=str(toys / "ToyFilter.fmu"))
    )
    # the first FMU's unpacked copy serves the second (same sources: fmu_src/bundle.py), not the clone's
    assert result["first"] == result["second"] and "/resources/oilwatch/fmu_src/" in result["first"]
    assert not result["cosim_loaded"]
    assert result["rows"] == 11


def test_an_fmu_with_other_oilwatch_sources_is_refused_naming_both_versions(toys, tmp_path):
    import json

    other = json.dumps({"version": "0.0.1", "digest": "0123456789abcdef"}).encode()
    tampered = edited_archive(
        toys / "ToyFilter.fmu", tmp_path / "ToyFilter.fmu", "resources/oilwatch/bundle.json", lambda _: other
    )
    result = run_json(
        PRELUDE
        + f"""
import oilwatch.cosim  # a host that imported oilwatch itself, from the clone
try:
    load({str(tampered)!r})
    outcome = "instantiated"
except Exception as error:
    outcome = type(error).__name__
result = {{"outcome": outcome, "log": LOG}}
"""
    )
    assert result["outcome"] != "instantiated"
    errors = [message for status, message in result["log"] if status >= 3]
    assert len(errors) == 1 and "\n" not in errors[0], errors
    assert "oilwatch 0.0.1 (sources 0123456789abcdef)" in errors[0]
    assert "but the process already imported oilwatch" in errors[0]
