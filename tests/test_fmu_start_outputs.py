"""The estimator FMU tells its host where its estimate is (fmu_src/ekf_start_outputs.py): whether the start
bank is still choosing, the start chosen, the time left until the choice and of the settling start, and
``estimate_settled``.

In a fresh process (tests/fixtures/fmu_subprocess.py) the slave is driven through its FMI calls with the
estimator model's own steady motion (as tests/test_fmu_start_bank.py), the bank's window shortened to 1.2 s:
the outputs must count down sample by sample, agree with the bank's own choice, keep ``estimate_settled``
false during both starts (even where ``converged`` is already true) and equal to ``converged`` after them, and
come back with a saved state. One filter (no viscosity factors) must say so plainly: not choosing, start 1,
nothing left, settled exactly when converged.

The built FMU (slow: ``built_fmus``), with the window shortened to 0.3 s in its start bank
before initialization, run on the loader's fast path and with ``OILWATCH_FMU_FAST_PATH=0``, must give the
same start outputs bit for bit, restore them with fmi2SetFMUstate and start them again after fmi2Reset; the
plain configuration must keep its compiled step and publish the constant start outputs and
``estimate_settled`` = ``converged`` from it.
"""

from __future__ import annotations

import numpy as np
from fixtures.fmu_subprocess import run_json
from test_ekf_fmu import FMPY_PRELUDE, TIMEOUT_S
from test_estimate_model_cache import STORED

SELECT_S = 1.2
RUN = f"""
import numpy as np
from oilwatch.estimator import start_bank
start_bank.SELECT_S = {SELECT_S}  # before the slave builds its estimator
"""
RUN += """
from oilwatch.fmu_src.oilwatch_ekf_slave import OilFlowEKF
from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import build_system
from oilwatch.models.system.operating_model import build_operating_model
from tests.test_nuisance_start import DT, _record

machine = load_machine()
model = build_operating_model(build_system(machine, reduced=True), machine, DT)
record = _record(model, 2000, 1.0)
REALS = ("start_fraction", "start_choice_in_s", "settling_start_left_s")
FLAGS = ("start_choosing", "estimate_settled", "converged")

def slave_of(name, factor_std):
    slave = OilFlowEKF(instance_name=name, resources=None)
    vr = {v.name: v.value_reference for v in slave.vars.values()}
    slave.setup_experiment(0.0, None, None)
    slave.set_string([vr["preset"]], ["paper"])  # the configuration whose starts these checks were made on
    slave.set_integer([vr["bearing_table"]], [1])
    slave.set_real([vr["viscosity_factor_prior_std"]], [factor_std])
    slave.exit_initialization_mode()
    return slave, vr

def rows(slave, vr, k0, k1):
    ports = [vr[f"{n}_um"] for n in ("x1", "y1", "x2", "y2")]
    out = []
    for k in range(k0, k1):
        slave.set_real(ports, (record[k] * 1e6).tolist())
        slave.do_step(k * DT, DT)
        out.append(row(slave, vr))
    return out

def row(slave, vr):
    flags = slave.get_boolean([vr[n] for n in FLAGS])
    counts = [slave.filter.step_count, getattr(slave.filter, "active_fraction", 1.0)]
    return slave.get_real([vr[n] for n in REALS]) + [int(b) for b in flags] + counts

result = {}
bank, vr = slave_of("bank", 0.1)
result["bank_initial"] = row(bank, vr)
result["settling_steps"] = bank.filter.settling_steps
first = rows(bank, vr, 0, 1000)
inside = bank._fmu_state_to_bytes(bank._get_fmu_state())
second = rows(bank, vr, 1000, 2000)
result["chosen"] = bank.filter.chosen_fraction
result["fractions"] = list(bank.filter.fractions)
bank._set_fmu_state(bank._fmu_state_from_bytes(inside))
result["restored"] = row(bank, vr)
result["again"] = rows(bank, vr, 1000, 2000) == second
result["bank"] = first + second
single, vr = slave_of("single", 0.0)
result["single_kind"] = type(single.filter).__name__
result["single_initial"] = row(single, vr)
result["single"] = rows(single, vr, 0, 2000)
"""


def test_the_start_outputs_follow_the_bank_and_the_settling_start_and_are_plain_for_one_filter():
    result = run_json(RUN, timeout=600)
    dt = 1e-3
    settling = result["settling_steps"]
    assert settling > 0  # free factors without a baseline: a settling start
    fraction, choice_in, settling_left, choosing, settled, converged, steps, _ = result["bank_initial"]
    assert (fraction, choosing, settled) == (1.0, 1, 0)  # the nominal start leads
    assert abs(choice_in - SELECT_S) < 1e-12 and abs(settling_left - (settling + 1) * dt) < 1e-12
    bank = np.array(result["bank"])
    fraction, choice_in, settling_left, choosing, settled, converged, steps, active = bank.T
    choice_step = round(SELECT_S / dt)
    # counted in the filter's samples: the time left is the samples left (the first step also predicts
    # through its start sample, so the filter's step count leads the FMU's steps by one)
    assert np.allclose(choice_in, np.maximum(choice_step - steps, 0) * dt, rtol=0, atol=1e-12)
    assert np.allclose(settling_left, np.maximum(settling + 1 - steps, 0) * dt, rtol=0, atol=1e-12)
    assert (choosing == (steps < choice_step)).all()
    assert result["chosen"] in result["fractions"]
    assert (fraction == active).all() and (fraction[choosing == 0] == result["chosen"]).all()
    started = (choosing == 1) | (settling_left > 0)
    assert (settled[started] == 0).all() and (settled[~started] == converged[~started]).all()
    masked = int(np.sum(started & (converged == 1)))
    after = int(np.sum(~started & (converged == 1)))
    print(f"chosen {result['chosen']}; converged during the starts on {masked} samples, after on {after}")
    assert masked > 0 and after > 0  # both branches of estimate_settled are exercised
    assert result["restored"] == result["bank"][999] and result["again"]  # a saved state brings them back

    assert result["single_kind"] == "OilFlowEKF"
    single = np.array([result["single_initial"], *result["single"]])
    fraction, choice_in, settling_left, choosing, settled, converged, _, _ = single.T
    assert (fraction == 1.0).all() and (choice_in == 0.0).all() and (settling_left == 0.0).all()
    assert (choosing == 0).all() and (settled == converged).all() and converged.any() and not converged.all()


BUILT = """
import os, sys, ctypes
from pathlib import Path
import numpy as np
DT = 1e-3
record = np.load(STORED)["constant/record"] * 1e6  # a stored plant record at constant conditions
md = read_model_description(EKF)
vr = {v.name: v.valueReference for v in md.modelVariables}
REALS = [vr[n] for n in ("start_fraction", "start_choice_in_s", "settling_start_left_s", "q1_est_ml_min")]
FLAGS = [vr[n] for n in ("start_choosing", "estimate_settled", "converged")]
IN = [vr[n] for n in ("x1_um", "y1_um", "x2_um", "y2_um")]
FREE = {"viscosity_factor_prior_std": 0.1, "noise_um": 1.0}

def initialize(slave, reals, integers):
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.setString([vr["preset"]], ["paper"])  # the configuration whose starts these checks were made on
    for key, value in reals.items():
        slave.setReal([vr[key]], [value])
    for key, value in integers.items():
        slave.setInteger([vr[key]], [value])
    bank = [m for name, m in sys.modules.items() if name == "oilwatch.estimator.start_bank"]
    for module in bank:  # the FMU's start bank: a window the record outlasts
        module.SELECT_S = 0.3
    slave.exitInitializationMode()
    return len(bank)

def instance(name, reals, integers):
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(EKF),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    slave.instantiate(callbacks=CALLBACKS, loggingOn=True)
    return slave, initialize(slave, reals, integers)

def row(slave):
    return slave.getReal(REALS) + [int(b) for b in slave.getBoolean(FLAGS)]

def run(slave, k0, k1):
    rows = []
    for k in range(k0, k1):
        slave.setReal(IN, record[k].tolist())
        slave.doStep(k * DT, DT)
        rows.append(row(slave))
    return rows

def compiled(slave):
    binary = Path(slave.unzipDirectory) / "binaries" / "linux64" / (slave.modelIdentifier + ".so")
    return ctypes.CDLL(str(binary)).oilwatch_loader_compiled_step(ctypes.c_void_p(slave.component))

result = {}
os.environ["OILWATCH_FMU_FAST_PATH"] = "0"
slow, _ = instance("slow", FREE, {"bearing_table": 1})
del os.environ["OILWATCH_FMU_FAST_PATH"]
fast, result["patched"] = instance("fast", FREE, {"bearing_table": 1})
for name, slave in (("fast", fast), ("slow", slow)):
    initial = row(slave)
    first = run(slave, 0, 200)
    state = slave.getFMUstate()
    second = run(slave, 200, 800)
    slave.setFMUstate(state)
    restored = row(slave)
    again = run(slave, 200, 800)
    slave.reset()
    reset = row(slave)
    initialize(slave, FREE, {"bearing_table": 1})
    result[name] = {"initial": initial, "first": first, "second": second, "restored": restored,
                    "again": again, "reset": reset, "after_reset": run(slave, 0, 200)}
plain, _ = instance("plain", {"noise_um": 1.0}, {})
result["plain_compiled"] = compiled(plain)
result["plain"] = [row(plain)] + run(plain, 0, len(record))
"""


def test_the_built_fmu_publishes_the_start_outputs_on_both_paths_and_keeps_the_compiled_plain_step(
    built_fmus,
):
    paths = f"EKF = {str(built_fmus / 'OilFlowEKF.fmu')!r}\nSTORED = {str(STORED)!r}\n"
    result = run_json(FMPY_PRELUDE + paths + BUILT, timeout=TIMEOUT_S)
    assert result["patched"] >= 1
    fast, slow = result["fast"], result["slow"]
    assert fast == slow  # bit for bit (JSON keeps every digit)
    rows = np.array(fast["first"] + fast["second"])
    choosing = rows[:, 4]
    assert choosing[0] == 1 and choosing[-1] == 0  # the choice falls inside the record
    fraction, choice_in, settling_left, _, choosing, settled, _ = fast["initial"]
    assert (fraction, choosing, settled) == (1.0, 1, 0) and abs(choice_in - 0.3) < 1e-12 and settling_left > 0
    assert fast["restored"] == fast["first"][-1] and fast["again"] == fast["second"]
    assert fast["reset"][4] == 0  # fmi2Reset: the start values until initialized again
    assert fast["after_reset"] == fast["first"]
    assert result["plain_compiled"] == 1  # the start outputs keep the compiled plain step
    plain = np.array(result["plain"])
    assert (plain[:, :3] == [1.0, 0.0, 0.0]).all() and (plain[:, 4] == 0).all()
    assert (plain[:, 5] == plain[:, 6]).all() and plain[:, 6].any()  # settled exactly when converged
