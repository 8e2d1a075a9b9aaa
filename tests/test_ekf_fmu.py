"""The OilFlowEKF FMU fed by the RotorBearingPlant FMU (issue 6, "done when").

The truth is the plant FMU (full finite-element model, sub-stepped trapezoidal rule), never the estimator's
own discrete model. Both FMUs are built once per session by ``oilwatch.cosim.fmu_build.build_fmus`` in a
subprocess; every FMU
scenario runs in another fresh subprocess (so the EKF FMU always runs from a process that did not build it),
one per group of scenarios, because the estimator's numba kernels compile once per process (about 10 s).

Measured when written (sigma 1 um, default = recommended tuning, Gauss-Seidel, plant first): constant 80 %
flow, largest error over 5-6 s 0.62 % / 0.51 %, mean 0.11 % / 0.04 %; NIS mean over a 20 s nominal run
3.98 (4 channels); alarm 0.455 s after the centre of a sudden 25 % drop of bearing 1, none on bearing 2 and
none in the nominal run; Jacobi with t_sample_s connected gives the Gauss-Seidel estimates one step later,
without it NIS 6.4 (misaligned by one step).
"""

from __future__ import annotations

import math
import zipfile

import pytest
from fixtures.fmu_subprocess import REPO_ROOT, run_json

QN = 596.3
TIMEOUT_S = 400.0

COSIM = """
import sys
import numpy as np
from oilwatch.cosim import Connection, FmuSpec, Master, SystemDescription
QN = 596.3
REC = ["ekf.q1_est_ml_min", "ekf.q2_est_ml_min", "ekf.nis", "ekf.n_channels", "ekf.starved1",
       "ekf.starved2", "ekf.measurement_ok", "ekf.t_estimate_s"]

def flows(q1a, q1b=None, q2a=None, **extra):
    q2a = q1a if q2a is None else q2a
    return {"q1_initial_ml_min": q1a, "q1_final_ml_min": q1a if q1b is None else q1b,
            "q2_initial_ml_min": q2a, "q2_final_ml_min": q2a, **extra}

def simulate(master, stop, plant, method="gauss-seidel", step=1e-3):
    run = master.run(stop_time=stop, step_size=step, method=method, record=REC, parameters={"plant": plant})
    return run.recorder.arrays()

def errors(a, truth, after):
    sel = a["time"] > after
    return {"max": [float(np.abs(a[f"ekf.q{b}_est_ml_min"][sel] / truth - 1).max()) for b in (1, 2)],
            "mean": [float(a[f"ekf.q{b}_est_ml_min"][sel].mean() / truth - 1) for b in (1, 2)]}

def nis_mean(a):
    return float(a["ekf.nis"][a["time"] > 2.0].mean())

# the paper's calibrated filter (nuisances known): the figures below are that configuration's
fmus = [FmuSpec("plant", PLANT, {"noise_um": 1.0, "seed": 11}),
        FmuSpec("ekf", EKF, {"noise_um": 1.0, "preset": "paper"})]
untimed = [Connection("plant", n, "ekf", n) for n in ("x1_um", "y1_um", "x2_um", "y2_um")]
q = 0.8 * QN
result = {}
with Master(SystemDescription(fmus)) as master:
    gs = simulate(master, 6.0, flows(q))
    result["init_log"] = list(master.slaves["ekf"].log)
    result["constant"] = errors(gs, q, 5.0)
    result["constant_nis"] = nis_mean(gs)
    jac = simulate(master, 6.0, flows(q), "jacobi")
    late = jac["time"][1:] > 1.0  # Jacobi also uses the plant's initial sample (t = 0), GS cannot
    result["jacobi_minus_gs_one_step_late"] = max(
        float(np.abs(jac[f"ekf.q{b}_est_ml_min"][1:][late] - gs[f"ekf.q{b}_est_ml_min"][:-1][late]).max())
        for b in (1, 2))
    result["jacobi_lag_s"] = float(np.median(jac["time"][1:] - jac["ekf.t_estimate_s"][1:]))
    nominal = simulate(master, 20.0, flows(QN))
    result["nominal"] = errors(nominal, QN, 5.0)
    result["nominal_nis"] = nis_mean(nominal)
    result["nominal_channels"] = sorted(set(nominal["ekf.n_channels"][1:].tolist()))
    result["nominal_ok"] = bool(nominal["ekf.measurement_ok"][1:].all())
    result["nominal_alarms"] = [int(nominal[f"ekf.starved{b}"].sum()) for b in (1, 2)]
    coarse = simulate(master, 6.0, flows(q), step=2e-3)  # the filter predicts through every other period
    result["coarse"] = errors(coarse, q, 5.0)
    result["coarse_lag_s"] = float(np.max(np.abs(coarse["time"][1:] - coarse["ekf.t_estimate_s"][1:])))
    drop = simulate(master, 14.0, flows(QN, 0.75 * QN, fault_time_s=10.0, fault_duration_s=0.1))
    result["alarm_times"] = [
        [float(t) for t in drop["time"][drop[f"ekf.starved{b}"] > 0.5][:1]] for b in (1, 2)]
    after = drop["time"] > 13.0
    result["drop_after"] = [float(np.abs(drop["ekf.q1_est_ml_min"][after] / (0.75 * QN) - 1).max()),
                            float(np.abs(drop["ekf.q2_est_ml_min"][after] / QN - 1).max())]
    result["ekf_module"] = sys.modules["oilwatch.estimator.ekf"].__file__
with Master(SystemDescription(fmus, connections=untimed)) as master:
    result["gs_untimed_identical"] = bool(
        np.array_equal(simulate(master, 6.0, flows(q))["ekf.q1_est_ml_min"], gs["ekf.q1_est_ml_min"]))
    result["jacobi_untimed_nis"] = nis_mean(simulate(master, 6.0, flows(q), "jacobi"))
result["jacobi_timed_nis"] = nis_mean(jac)
"""

FMPY_PRELUDE = """
import math
from ctypes import byref
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (FMU2Slave, calloc, free, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE,
                       fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE)
from fmpy.logging import addLoggerProxy
LOG = []

def _logger(env, instance, status, category, message):
    LOG.append((instance.decode(), status, message.decode()))

CALLBACKS = fmi2CallbackFunctions()
CALLBACKS.logger = fmi2CallbackLoggerTYPE(_logger)
CALLBACKS.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
CALLBACKS.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
addLoggerProxy(byref(CALLBACKS))

def load(path, name, reals=None, integers=None, strings=None):
    md = read_model_description(path)
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(path),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    slave.instantiate(callbacks=CALLBACKS, loggingOn=True)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    for key, value in (reals or {}).items():
        slave.setReal([vr[key]], [value])
    for key, value in (integers or {}).items():
        slave.setInteger([vr[key]], [value])
    for key, value in (strings or {}).items():
        slave.setString([vr[key]], [value])
    slave.exitInitializationMode()
    return slave, vr

PORTS = ["x1_um", "y1_um", "x2_um", "y2_um", "t_sample_s"]

def cosimulate(plant, pv, filters, steps, outputs, h=1e-3):
    # step the plant and each filter {name: (slave, vr)} or {name: (slave, vr, ports)} fed its ports (default
    # PORTS) from the plant's outputs of the same names; per filter the rows of outputs
    ports = {name: (f[2] if len(f) > 2 else PORTS) for name, f in filters.items()}
    names = list(dict.fromkeys(n for p in ports.values() for n in p))
    src = [pv[n] for n in names]
    picks = {name: [names.index(n) for n in p] for name, p in ports.items()}
    rows = {name: [] for name in filters}
    for k in range(steps):
        plant.doStep(k * h, h)
        values = plant.getReal(src)
        for name, (ekf, ev, *_) in filters.items():
            ekf.setReal([ev[n] for n in ports[name]], [values[i] for i in picks[name]])
            ekf.doStep(k * h, h)
            rows[name].append(ekf.getReal([ev[n] for n in outputs]))
    return rows
"""

DIRECT = """
q = 0.8 * 596.3
flow = {f"q{b}_{s}_ml_min": q for b in (1, 2) for s in ("initial", "final")}
plant, pv = load(PLANT, "plant", {"noise_um": 1.0, **flow}, {"seed": 5})
ekf, ev = load(EKF, "ekf", {"noise_um": 1.0}, strings={"preset": "paper"})
PORTS = ["x1_um", "y1_um", "x2_um", "y2_um", "t_sample_s"]
src, dst = [pv[n] for n in PORTS], [ev[n] for n in PORTS]
REALS = [ev[n] for n in ("q1_est_ml_min", "q2_est_ml_min", "q1_std_ml_min", "q2_std_ml_min", "nis",
                         "t_estimate_s")]
BOOLS = [ev[n] for n in ("converged", "starved1", "starved2", "measurement_ok")]
h = 1e-3
# steps 2000-2099: one probe NaN, +inf or -inf in turn
BAD = {2000 + i: (i % 4, (math.nan, math.inf, -math.inf, math.nan)[i % 4]) for i in range(100)}
BAD.update({2500: (4, math.inf), 2501: (4, math.nan)})  # non-finite time stamps: skipped samples

def outputs():
    return ekf.getReal(REALS) + [float(v) for v in ekf.getBoolean(BOOLS)] + ekf.getInteger([ev["n_channels"]])

def run(k0, k1):
    rows = []
    for k in range(k0, k1):
        plant.doStep(k * h, h)
        values = plant.getReal(src)
        if k in BAD:
            values[BAD[k][0]] = BAD[k][1]
        ekf.setReal(dst, values)
        ekf.doStep(k * h, h)
        rows.append(outputs())
    return rows

rows = run(0, 3000)
result = {"ok": [r[9] for r in rows[1990:2110]], "finite": all(all(map(math.isfinite, r)) for r in rows),
          "stamp_ok": [r[9] for r in rows[2499:2503]], "stamp_t": [r[5] for r in rows[2499:2503]],
          "q_before": rows[1999][:2], "q_after": rows[2999][:2]}
for k in range(3000, 3005):  # the plant takes five steps, the filter one communication step of 5 h
    plant.doStep(k * h, h)
ekf.setReal(dst, plant.getReal(src))
ekf.doStep(3000 * h, 5 * h)
result["gap"] = outputs()
ekf.doStep(3005 * h, h)  # no new sample: t_sample_s has not advanced
result["repeated"] = outputs()
plant.doStep(3005 * h, h)
ekf.setReal(dst, plant.getReal(src))
ekf.doStep(3006 * h, h)  # the plant's sample of 3.006 s arrives in the step that ends at 3.007 s
result["late"] = outputs()
run(3006, 5000)
plant_state, ekf_state = plant.getFMUstate(), ekf.getFMUstate()
first = run(5000, 6000)
plant.setFMUstate(plant_state)
ekf.setFMUstate(ekf_state)
second = run(5000, 6000)
plant.setFMUstate(plant_state)
ekf.setFMUstate(ekf.deSerializeFMUstate(ekf.serializeFMUstate(ekf_state)))
third = run(5000, 6000)
result.update(first=first, second=second, third=third)
# The same FMU serves the machine of an explicit machine file, here with the paper's eight channels.
other, ov = load(EKF, "other", {"noise_um": 1.0}, {"velocity_channels": 1},
                 {"machine_file": MACHINE, "preset": "paper"})
for k in range(6000, 6300):
    plant.doStep(k * h, h)
    other.setReal([ov[n] for n in PORTS], plant.getReal(src))
    other.doStep(k * h, h)
result["other"] = other.getReal([ov["q1_est_ml_min"], ov["q2_est_ml_min"]])
result["other"] += other.getInteger([ov["n_channels"]])
"""

ERRORS = """
CASES = [
    ("noise_um", {"reals": {"noise_um": -1.0}}),
    ("alarm_off_fraction", {"reals": {"alarm_off_fraction": 0.8}}),
    ("q2_initial_ml_min", {"reals": {"q2_initial_ml_min": 100.0}}),
    # the paper preset's grid model holds one speed (the machine preset follows the measured speed)
    ("speed_hz", {"reals": {"speed_hz": 60.0}, "strings": {"preset": "paper"}}),
    ("q_std_velocity_um_s", {"reals": {"q_std_velocity_um_s": -0.5}}),
    ("velocity_channels", {"integers": {"velocity_channels": 2}}),
    ("machine_file", {"strings": {"machine_file": "/no/such/machine.toml"}}),
]
result = {}
for index, (name, values) in enumerate(CASES):
    instance = f"ekf{index}"
    try:
        slave, _ = load(EKF, instance, **values)
        outcome = "initialized"
    except FMICallException as error:
        outcome = [error.function, error.status]
    errors = [m for i, status, m in LOG if i == instance and status == 3]
    result[name] = {"outcome": outcome, "errors": errors}
"""


def _run(fmus, body: str, prelude: str = ""):
    paths = (
        f"PLANT, EKF = {str(fmus / 'RotorBearingPlant.fmu')!r}, {str(fmus / 'OilFlowEKF.fmu')!r}\n"
        f"MACHINE = {str(REPO_ROOT / 'models' / 'turbine.toml')!r}\n"
    )
    return run_json(prelude + paths + body, timeout=TIMEOUT_S)


@pytest.fixture(scope="module")
def cosim(built_fmus):
    return _run(built_fmus, COSIM)


@pytest.fixture(scope="module")
def direct(built_fmus):
    return _run(built_fmus, DIRECT, FMPY_PRELUDE)


def test_constant_80_percent_estimates_within_3_percent_after_5_s(cosim):
    assert max(cosim["constant"]["max"]) < 0.03, cosim["constant"]
    # The mean error is far smaller (0.1 % measured): the 3 % bound is not what keeps this test honest.
    assert max(abs(e) for e in cosim["constant"]["mean"]) < 0.01


def test_nis_averages_the_number_of_channels_over_a_nominal_run(cosim):
    # A consistent filter's NIS is chi-square with m = 4 (displacement channels): mean 4, and the mean of
    # 18000 white samples scatters by 0.5 %. The 10 % tolerance leaves room for the reduced grid model's
    # mismatch with the full-order plant, and still fails the paper's Q (NIS/m 0.14 measured) and a sample
    # misaligned by one step (NIS 6.4, below).
    assert cosim["nominal_channels"] == [4.0] and cosim["nominal_ok"]
    assert cosim["nominal_nis"] == pytest.approx(4.0, rel=0.1)
    assert cosim["constant_nis"] == pytest.approx(4.0, rel=0.1)
    assert max(cosim["nominal"]["max"]) < 0.03


def test_no_alarm_in_a_20_s_nominal_run(cosim):
    assert cosim["nominal_alarms"] == [0, 0]


def test_alarm_fires_within_2_s_of_a_sudden_25_percent_drop_on_that_bearing_only(cosim):
    first_b1, first_b2 = cosim["alarm_times"]
    assert first_b1 and 10.0 < first_b1[0] <= 12.0, cosim["alarm_times"]
    assert not first_b2
    assert max(cosim["drop_after"]) < 0.03


def test_time_stamp_keeps_the_filter_aligned_whatever_the_master_order(cosim):
    # Jacobi: the same samples arrive one step late with their own time stamp, so the estimates are the
    # Gauss-Seidel ones delayed by one step. Only the plant's initial sample (t = 0), which Jacobi feeds and
    # Gauss-Seidel cannot, differs: 0.001 ml/min measured after 1 s, against ~1 ml/min estimate std.
    assert cosim["jacobi_minus_gs_one_step_late"] < 0.01
    assert cosim["jacobi_lag_s"] == pytest.approx(1e-3, abs=1e-9)
    assert cosim["jacobi_timed_nis"] == pytest.approx(4.0, rel=0.1)
    # Unconnected t_sample_s means "end of the step": right for Gauss-Seidel (bit-identical), one step off
    # for Jacobi, which the consistency test sees.
    assert cosim["gs_untimed_identical"]
    assert cosim["jacobi_untimed_nis"] > 5.0


def test_a_communication_step_of_two_periods_is_predicted_through(cosim):
    assert max(cosim["coarse"]["max"]) < 0.03 and cosim["coarse_lag_s"] < 1e-9


def test_the_fmu_shares_the_hosts_oilwatch_when_its_sources_are_the_bundled_ones(cosim):
    # the master imported oilwatch from the clone first; the FMU bundles the same sources (fmu_src/bundle.py)
    assert "oilwatch_OilFlowEKF" not in cosim["ekf_module"]  # not the builder's staging folder
    assert "/resources/" not in cosim["ekf_module"]
    assert any("numba kernels compiled" in line for line in cosim["init_log"])


def test_nan_and_infinite_inputs_drop_their_channel_and_keep_the_state_finite(direct):
    assert direct["ok"] == [1.0] * 120  # one bad probe at a time: the other three update the filter
    assert direct["finite"]
    # an infinite or NaN t_sample_s is a skipped sample (predicted through), not a fatal error
    assert direct["stamp_ok"] == [1.0, 0.0, 0.0, 1.0]
    assert direct["stamp_t"] == pytest.approx([2.5, 2.501, 2.502, 2.503], abs=1e-9)
    for before, after in zip(direct["q_before"], direct["q_after"], strict=True):
        assert after == pytest.approx(0.8 * QN, rel=0.03) and math.isfinite(before)


def test_gap_is_predicted_through_and_a_repeated_sample_is_not_used_twice(direct):
    t_estimate, ok = 5, 9
    assert direct["gap"][t_estimate] == pytest.approx(3.005, abs=1e-9) and direct["gap"][ok] == 1.0
    assert direct["repeated"] == direct["gap"]
    assert direct["late"][t_estimate] == pytest.approx(3.006, abs=1e-9)
    assert direct["late"] != direct["gap"]


def test_state_restore_is_bit_identical(direct):
    assert direct["first"] == direct["second"] == direct["third"]
    t_estimate = 5
    assert direct["first"][-1][t_estimate] == pytest.approx(6.0, abs=1e-9)
    assert len({row[0] for row in direct["first"]}) > 100  # the estimate really moves


def test_another_machine_file_and_the_papers_velocity_channels(direct):
    q1, q2, channels = direct["other"]
    assert channels == 8
    assert all(math.isfinite(q) and 0.5 * QN < q < 1.5 * QN for q in (q1, q2))


def test_parameter_out_of_range_fails_initialization_naming_it(built_fmus):
    result = _run(built_fmus, ERRORS, FMPY_PRELUDE)
    for name, case in result.items():
        assert case["outcome"] == ["fmi2ExitInitializationMode", 3], (name, case)  # fmi2Error, not Fatal
        named = [m for m in case["errors"] if name in m and ("must" in m or ": no " in m)]
        assert named, (name, case)


def test_model_description_validates_and_documents_the_tuning(built_fmus):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    path = built_fmus / "OilFlowEKF.fmu"
    assert validate_fmu(str(path)) == []
    variables = {v.name: v for v in read_model_description(str(path)).modelVariables}
    expected = {
        "x1_um": ("input", "um"),
        "t_sample_s": ("input", "s"),
        "q1_est_ml_min": ("output", "ml/min"),
        "q2_std_ml_min": ("output", "ml/min"),
        "nis": ("output", "1"),
        "speed_hz": ("input", "Hz"),
        "oil_temperature_c": ("input", "degC"),
        "viscosity_factor_prior_std": ("parameter", "1"),
        "q_std_velocity_um_s": ("parameter", "um/s"),
    }
    for name, (causality, unit) in expected.items():
        assert (variables[name].causality, variables[name].unit) == (causality, unit)
    for name in ("converged", "starved1", "starved2", "measurement_ok"):
        assert variables[name].type == "Boolean" and variables[name].causality == "output"
    assert all(v.description for v in variables.values())
    with zipfile.ZipFile(path) as archive:
        page = archive.read("documentation/index.html").decode()
    assert "paper" in page and "NIS/m 0.14" in page
