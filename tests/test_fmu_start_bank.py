"""The estimator FMU runs the product's estimator (oilwatch.estimator.factory.make_estimator): with the
viscosity factors free (``bearing_table = 1``, ``viscosity_factor_prior_std = 0.1``) and no baseline, the
start bank.

In a fresh process (tests/fixtures/fmu_subprocess.py) the slave is driven through its FMI calls with the
estimator model's own steady motion at 80 % flow (as tests/test_start_bank.py), its window shortened to 1 s
to keep the record at 1.5 s. An in-process bank built by the factory with the FMU's configuration, fed the
same samples as the FMU feeds its filter (the warm-up and reset of initialization, the missing sample of
the first step's gap), must give the FMU's estimates after the choice, and the FMU's state saved inside the
window and after the choice (``fmi2GetFMUstate``, serialized as ``fmi2SerializeFMUstate`` does) must run on
bit for bit when restored.

The built FMU (slow: ``built_fmus``) with the same parameters, one instance on the loader's fast path and one
with ``OILWATCH_FMU_FAST_PATH=0``, fed the same stored plant record inside the bank's window (its 20 s: five
filters per step), must give bit-identical outputs, restore a saved state bit for bit, and after ``fmi2Reset``
and a new initialization run the record again as at first.
"""

from __future__ import annotations

import numpy as np
from fixtures.fmu_subprocess import run_json
from test_ekf_fmu import FMPY_PRELUDE, TIMEOUT_S
from test_estimate_model_cache import STORED

RUN = """
import numpy as np
from oilwatch.estimator import start_bank
start_bank.SELECT_S = 1.0  # before the slave builds its estimator
from oilwatch.estimator.factory import make_estimator
from oilwatch.estimator.ekf_config import ML_MIN
from oilwatch.fmu_src.oilwatch_ekf_slave import OilFlowEKF
from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import build_system
from oilwatch.models.system.operating_model import build_operating_model
from tests.test_nuisance_start import DT, _record

machine = load_machine()
model = build_operating_model(build_system(machine, reduced=True), machine, DT)
record = _record(model, 1500, 0.8)
slave = OilFlowEKF(instance_name="bank", resources=None)
vr = {v.name: v.value_reference for v in slave.vars.values()}
slave.setup_experiment(0.0, None, None)
slave.set_integer([vr["bearing_table"]], [1])
slave.set_real([vr["viscosity_factor_prior_std"]], [0.1])
slave.exit_initialization_mode()
PORTS = [vr[f"{n}_um"] for n in ("x1", "y1", "x2", "y2")]
OUT = [vr[n] for n in ("q1_est_ml_min", "q2_est_ml_min", "q1_std_ml_min", "q2_std_ml_min", "nis")]

def run(k0, k1):
    rows = []
    for k in range(k0, k1):
        slave.set_real(PORTS, (record[k] * 1e6).tolist())
        slave.do_step(k * DT, DT)
        rows.append(slave.get_real(OUT))
    return rows

first = run(0, 600)
inside = slave._fmu_state_to_bytes(slave._get_fmu_state())
second = run(600, 1200)
after = slave._fmu_state_to_bytes(slave._get_fmu_state())
third = run(1200, 1500)
slave._set_fmu_state(slave._fmu_state_from_bytes(inside))
second_again = run(600, 1200)
slave._set_fmu_state(slave._fmu_state_from_bytes(after))
third_again = run(1200, 1500)

bank = make_estimator(model, slave.filter.config)
speed, temperature = machine.nominal_speed_hz, machine.nominal_oil_temperature_c
missing = np.full(4, np.nan)
for sample in (np.zeros(4), np.zeros(4), missing):  # the slave's warm-up
    bank.step(sample, speed, temperature)
bank.reset()
bank.step(missing, speed, temperature)  # the first step's sample lies one period after the start
ours = [bank.step((record[k] * 1e6) * 1e-6, speed, temperature).q_m3_s / ML_MIN for k in range(1500)]
result = {
    "kind": type(slave.filter).__name__, "chosen": slave.filter.chosen_fraction,
    "bank_chosen": bank.chosen_fraction, "fmu": [r[:2] for r in first + second + third],
    "bank": np.array(ours).tolist(), "again": [second == second_again, third == third_again],
}
"""


def test_the_fmu_with_free_factors_runs_the_start_bank_and_restores_its_state():
    result = run_json(RUN, timeout=600)
    assert result["kind"] == "StartBank" and result["chosen"] is not None
    assert result["chosen"] == result["bank_chosen"]
    fmu, bank = result["fmu"], result["bank"]
    assert len(fmu) == len(bank) == 1500
    fmu, bank = np.array(fmu), np.array(bank)
    largest = float(np.max(np.abs(fmu / bank - 1.0)))
    print(f"chosen start {result['chosen']}; largest relative gap FMU / in-process bank {largest:.2e}")
    assert largest <= 1e-9, largest
    assert (fmu[-1] != fmu[998]).all()  # the estimate moves on after the choice
    assert result["again"] == [True, True]


BUILT = """
import os
import numpy as np
DT = 1e-3
record = np.load(STORED)["constant/record"][:600] * 1e6  # a stored plant record at constant conditions
FREE = {"viscosity_factor_prior_std": 0.1, "noise_um": 1.0}
os.environ["OILWATCH_FMU_FAST_PATH"] = "0"
slow, vr = load(EKF, "slow", FREE, {"bearing_table": 1})
del os.environ["OILWATCH_FMU_FAST_PATH"]
fast, _ = load(EKF, "fast", FREE, {"bearing_table": 1})
IN = [vr[n] for n in ("x1_um", "y1_um", "x2_um", "y2_um")]
OUT = [vr[n] for n in ("q1_est_ml_min", "q2_est_ml_min", "q1_std_ml_min", "q2_std_ml_min", "nis",
                       "viscosity_factor_b1", "offset_x1_um")]

def run(slave, k0, k1):
    rows = []
    for k in range(k0, k1):
        slave.setReal(IN, record[k].tolist())
        slave.doStep(k * DT, DT)
        rows.append(slave.getReal(OUT))
    return rows

result = {}
for name, slave in (("fast", fast), ("slow", slow)):
    first = run(slave, 0, 300)
    state = slave.getFMUstate()
    second = run(slave, 300, 600)
    slave.setFMUstate(state)
    again = run(slave, 300, 600)
    slave.reset()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    for key, value in FREE.items():
        slave.setReal([vr[key]], [value])
    slave.setInteger([vr["bearing_table"]], [1])
    slave.exitInitializationMode()
    result[name] = {"first": first, "second": second, "again": again, "after_reset": run(slave, 0, 300)}
"""


def test_the_built_fmu_runs_the_bank_on_the_fast_path_and_restores_and_resets_it(built_fmus):
    paths = f"EKF = {str(built_fmus / 'OilFlowEKF.fmu')!r}\nSTORED = {str(STORED)!r}\n"
    result = run_json(FMPY_PRELUDE + paths + BUILT, timeout=TIMEOUT_S)
    fast, slow = result["fast"], result["slow"]
    assert fast == slow  # bit for bit (JSON keeps every digit)
    assert fast["again"] == fast["second"] and fast["after_reset"] == fast["first"]
    assert len({row[0] for row in fast["second"]}) > 100  # the estimate moves after the settling start
