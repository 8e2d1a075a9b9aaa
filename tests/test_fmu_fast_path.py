"""The estimator FMU's fast path (issue 14: its step within 50 us): the FMU's loader serves the per-step
inputs and outputs in C and calls the slave's step directly (``oilwatch/cosim/native/fmi2_loader.c``,
``fmu_src/slave_base.py``). It must change nothing a host can see.

One fresh process runs the plant FMU and two instances of the estimator FMU fed the same plant outputs: one
with the fast path, one initialized with ``OILWATCH_FMU_FAST_PATH=0`` (pythonfmu's path for every call).
Over the run some probes read NaN or infinity, one time stamp is infinite, one sample is off the filter's
grid (a logged warning: the step is replayed through pythonfmu), one sample repeats, both instances save and
restore their state, and both get a fixed parameter set after initialization. Every output (reals, integers,
booleans, the nuisance estimates) must be bit-identical between the two, the refused set must be fmi2Error
on both with the same message, and a step that fails (a time stamp after the step's end) must be fmi2Fatal
with the slave's message on both. ``fmi2Reset`` drops the binding; the next initialization binds again.
The estimators run the paper preset (the plain configuration): the fast instance's plain samples, the first
one among them (after the start time's sample, taken ahead in initialization), run in the compiled step
(``fmu_src/ekf_plain_step.py``, without the GIL); the others (a non-finite, off-grid or repeated time stamp, a
failing step) decline to the slave's Python step.

Also here (the same slave's parameters, in process): ``baseline_age_days`` widens the baseline's offsets prior
by the machine file's ``[probes] offset_drift_um_per_day``, and the runout the filter subtracts is the
``baseline_file``'s when it has one, else the machine file's ``[probes]`` keys (as ``oilwatch estimate``).
"""

from __future__ import annotations

import math

import pytest
from fixtures.fmu_subprocess import REPO_ROOT, run_json
from test_ekf_fmu import FMPY_PRELUDE, TIMEOUT_S

RUN = """
import ctypes, math, os
from pathlib import Path
q = 0.85 * 596.3
flow = {f"q{b}_{s}_ml_min": q for b in (1, 2) for s in ("initial", "final")}
plant, pv = load(PLANT, "plant", {"noise_um": 1.0, **flow}, {"seed": 3})

def loader_bound(slave, entry="oilwatch_loader_fast_path"):
    binary = Path(slave.unzipDirectory) / "binaries" / "linux64" / (slave.modelIdentifier + ".so")
    return getattr(ctypes.CDLL(str(binary)), entry)(ctypes.c_void_p(slave.component))

PAPER = {"preset": "paper"}  # the plain configuration: the grid model at one speed, the compiled plain step
os.environ["OILWATCH_FMU_FAST_PATH"] = "0"
slow, ev = load(EKF, "slow", {"noise_um": 1.0}, strings=PAPER)
del os.environ["OILWATCH_FMU_FAST_PATH"]
fast, _ = load(EKF, "fast", {"noise_um": 1.0}, strings=PAPER)
COMPILED = "oilwatch_loader_compiled_step"
result = {"bound": [loader_bound(fast), loader_bound(slow)]}
result["compiled"] = [loader_bound(fast, COMPILED), loader_bound(slow, COMPILED)]
PORTS = ["x1_um", "y1_um", "x2_um", "y2_um", "t_sample_s"]
src, dst = [pv[n] for n in PORTS], [ev[n] for n in PORTS]
md = read_model_description(EKF)
outputs = [v for v in md.modelVariables if v.causality == "output"]
by_type = {t: [ev[v.name] for v in outputs if v.type == t] for t in ("Real", "Integer", "Boolean")}
CORE = [ev[n] for n in ("q1_est_ml_min", "q2_est_ml_min", "nis", "t_estimate_s")]
h = 1e-3
BAD = {300 + i: (i % 4, (math.nan, math.inf, -math.inf, math.nan)[i % 4]) for i in range(40)}
BAD.update({500: (4, math.inf), 700: (4, 0.7003)})  # a non-finite and an off-grid time stamp

def row(ekf, k):
    values = ekf.getReal(CORE) + ekf.getReal(by_type["Real"]) if k % 50 == 0 else ekf.getReal(CORE)
    return values + ekf.getInteger(by_type["Integer"]) + [int(b) for b in ekf.getBoolean(by_type["Boolean"])]

def run(k0, k1):
    rows = {"fast": [], "slow": []}
    for k in range(k0, k1):
        plant.doStep(k * h, h)
        values = plant.getReal(src)
        if k in BAD:
            values[BAD[k][0]] = BAD[k][1]
        for name, ekf in (("fast", fast), ("slow", slow)):
            ekf.setReal(dst, values)
            ekf.doStep(k * h, h)
            if k == 900:
                ekf.doStep(k * h + h, h)  # no new sample: a repeated one, not used twice
            rows[name].append(row(ekf, k))
    return rows

first = run(0, 1000)
states = {"fast": fast.getFMUstate(), "slow": slow.getFMUstate(), "plant": plant.getFMUstate()}
second = run(1000, 1200)
for name, slave in (("fast", fast), ("slow", slow), ("plant", plant)):
    slave.setFMUstate(states[name])
again = run(1000, 1200)
refused = {}
for name, ekf in (("fast", fast), ("slow", slow)):
    try:
        ekf.setReal([ev["noise_um"], ev["x1_um"]], [3.0, 0.0])
        refused[name] = 0
    except FMICallException as error:
        refused[name] = error.status
third = run(1200, 1300)
result.update(first=first, second=second, again=again, third=third, refused=refused)
def messages(text):
    return {n: [m for i, s, m in LOG if i == n and text in m] for n in ("fast", "slow")}

result["refusal_log"] = messages("fixed parameter")
result["off_grid_log"] = messages("off the filter's grid")
fast.reset()
result["bound_after_reset"] = loader_bound(fast)
fast.setupExperiment(startTime=0.0)
fast.enterInitializationMode()
fast.setReal([ev["noise_um"]], [1.0])
fast.setString([ev["preset"]], ["paper"])
fast.exitInitializationMode()
result["bound_after_reinitialization"] = [loader_bound(fast), loader_bound(fast, COMPILED)]
failed = {}
for name, ekf in (("fast", fast), ("slow", slow)):
    ekf.setReal([ev["t_sample_s"]], [99.0])  # after the end of the step: the slave raises
    try:
        ekf.doStep(5.0, h)
        failed[name] = 0
    except FMICallException as error:
        failed[name] = error.status
result["failed"] = failed
result["failed_log"] = messages("t_sample_s = 99")
"""


def test_the_fast_path_changes_no_output_status_or_message(built_fmus):
    plant, ekf = (str(built_fmus / name) for name in ("RotorBearingPlant.fmu", "OilFlowEKF.fmu"))
    paths = f"PLANT, EKF = {plant!r}, {ekf!r}\n"
    result = run_json(FMPY_PRELUDE + paths + RUN, timeout=TIMEOUT_S)
    assert result["bound"] == [1, 0]  # the fast instance is served by the loader, the other by pythonfmu
    assert result["compiled"] == [
        1,
        0,
    ]  # and its plain samples by the compiled step (fmu_src/ekf_plain_step.py)
    for part in ("first", "second", "again", "third"):
        assert result[part]["fast"] == result[part]["slow"], part  # bit for bit (JSON keeps every digit)
    assert result["second"] == result["again"]  # the restored state runs on identically
    assert len({r[0] for r in result["first"]["fast"]}) > 100  # the estimate really moves
    assert result["refused"] == {"fast": 3, "slow": 3}  # fmi2Error, and both step on
    assert all(len(messages) == 1 for messages in result["refusal_log"].values())
    assert result["refusal_log"]["fast"] == [m.replace("slow", "fast") for m in result["refusal_log"]["slow"]]
    assert all(len(messages) == 1 for messages in result["off_grid_log"].values())  # replayed, relayed
    assert result["bound_after_reset"] == 0 and result["bound_after_reinitialization"] == [1, 1]
    assert result["failed"] == {"fast": 3, "slow": 3}  # a refused step: fmi2Error, the reason on both
    fast_failure, slow_failure = result["failed_log"]["fast"], result["failed_log"]["slow"]
    assert fast_failure and fast_failure == [m.replace("slow", "fast") for m in slow_failure]


BASELINE = """
import json, math
from oilwatch.fmu_src.oilwatch_ekf_slave import OilFlowEKF
from oilwatch.estimator.runout import SlowRollVectors, runout_of_probes
from oilwatch.models.machine import load_machine
from oilwatch.models.probes import read_probes
ONE = {"format": "oilwatch commissioning baseline", "format_version": 1,
       "offsets_um": [1.0, -2.0, 3.0, -4.0], "offset_std_um": [0.5, 0.5, 0.5, 0.5]}
RUNOUT = {f"runout_{n}_{key}": [value] * 4
          for n, (um, deg) in {"1x": (1.5, 40.0), "2x": (0.5, -60.0)}.items()
          for key, value in (("um", um), ("phase_deg", deg), ("std_um", 0.05))}
open(PLAIN, "w").write(json.dumps(ONE))
open(WITH_RUNOUT, "w").write(json.dumps({**ONE, "runout": RUNOUT}))
result = {"drift_um_per_day": read_probes(load_machine()).offset_drift_m_per_day * 1e6}

def slave(name, days=0.0, baseline=PLAIN, machine=""):
    slave = OilFlowEKF(instance_name=name, resources=None)
    vr = {v.name: v.value_reference for v in slave.vars.values()}
    slave.setup_experiment(0.0, None, None)
    slave.set_string([vr["baseline_file"], vr["machine_file"]], [baseline, machine])
    slave.set_real([vr["baseline_age_days"]], [days])
    slave.exit_initialization_mode()
    return slave, vr

for days in (0.0, 100.0):
    aged, vr = slave(f"aged{days:g}", days)
    result[str(days)] = aged.get_real([vr["offset_y1_um"], vr["offset_y1_std_um"]])
baseline_runout = SlowRollVectors.from_document(RUNOUT, "test")
machine_runout = runout_of_probes(read_probes(load_machine(MACHINE)))
result["machine_file_has_runout"] = machine_runout is not None
result["runout"] = {}
for name, baseline, machine in (("plain_bundled", PLAIN, ""), ("plain_machine", PLAIN, MACHINE),
                                ("baseline_machine", WITH_RUNOUT, MACHINE)):
    runout = slave(name, baseline=baseline, machine=machine)[0].filter.config.runout
    result["runout"][name] = ("none" if runout is None else "baseline" if runout == baseline_runout
                              else "machine" if runout == machine_runout else "other")
"""


def test_the_baseline_age_and_runout_reach_the_estimator(tmp_path):
    # the slave class in a fresh process, without FMI: the parameters' effect, not the loader
    text = (REPO_ROOT / "models" / "turbine.toml").read_text(encoding="utf-8")
    keys = "runout_1x_um = 2.0\nrunout_1x_phase_deg = 30.0\nrunout_1x_std_um = 0.05\n"
    keys += "runout_2x_um = 1.0\nrunout_2x_phase_deg = -100.0\nrunout_2x_std_um = 0.05\n"
    text += "".join(f"\n[probes.{probe}]\n{keys}" for probe in ("x1", "y1", "x2", "y2"))
    (tmp_path / "turbine.toml").write_text(text, encoding="utf-8")
    (tmp_path / "tables").symlink_to(REPO_ROOT / "models" / "tables")
    files = {name: str(tmp_path / f"{name}.json") for name in ("PLAIN", "WITH_RUNOUT")}
    files["MACHINE"] = str(tmp_path / "turbine.toml")
    head = "".join(f"{name} = {path!r}\n" for name, path in files.items())
    result = run_json(head + BASELINE, timeout=TIMEOUT_S)
    drift = result["drift_um_per_day"]
    assert drift > 0.0
    (offset_new, std_new), (offset_old, std_old) = result["0.0"], result["100.0"]
    assert offset_new == offset_old == -2.0  # the baseline's offset is the prior's mean either way
    assert std_new == pytest.approx(0.5, rel=1e-9)
    assert std_old == pytest.approx(math.hypot(0.5, 100.0 * drift), rel=1e-9)
    # runout: the baseline's when it has one, else the machine file's [probes] keys (as oilwatch estimate)
    assert result["machine_file_has_runout"]
    expected = {"plain_bundled": "none", "plain_machine": "machine", "baseline_machine": "baseline"}
    assert result["runout"] == expected
