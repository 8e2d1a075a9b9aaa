"""The keyphasor at FMU level: plant and estimator FMUs under oilwatch's fmpy master, the estimator's
``rotor_angle_deg`` connected to the plant's output of the same name (issue 13 item 3; the library-level
test is ``tests/test_keyphasor.py``).

The plant FMU turns at 75.6 Hz (``bearing_table = 1``, its ``speed_hz`` input); both estimator FMUs run
``bearing_table = 1`` and are told nothing of the speed, so they take the nominal 75 Hz. One is connected by
name (the master's same-name matching, as ``oilwatch run`` wires it); the other has every connection but the
keyphasor, whose input stays at its start value -1 (not connected: the integral of the speed). Its unbalance
phase then slips by 0.6 rev/s; the connected one keeps the plant's phase at every sample. One run in a fresh
process; 4 s at 80 / 100 % flow.
"""

from __future__ import annotations

import pytest
from fixtures.fmu_subprocess import run_json

NOMINAL_ML_MIN = 596.3
TRUTH = (0.8 * NOMINAL_ML_MIN, 1.0 * NOMINAL_ML_MIN)
DURATION_S = 4.0

CODE = """
from fmpy import read_model_description
from oilwatch.cosim import Connection, FmuSpec, Master, SystemDescription
from oilwatch.cosim.connections import same_name_connections

plant = {"bearing_table": 1, "speed_hz": 75.6, "noise_um": 1.0, "seed": 5,
         **{f"q{b}_{s}_ml_min": q for b, q in ((1, Q1), (2, Q2)) for s in ("initial", "final")}}
ekf = {"bearing_table": 1, "noise_um": 1.0}
specs = [FmuSpec("plant", PLANT, plant), FmuSpec("ekf", EKF, ekf)]
# the master's same-name matching (what it does with no connections given) for the connected filter ...
variables = {s.name: read_model_description(s.path).modelVariables for s in specs}
wired = [c for c in same_name_connections(variables) if c.end_element == "ekf"]
# ... and the same wiring minus the keyphasor for the other
free = [Connection(c.start_element, c.start_connector, "ekf_free", c.end_connector)
        for c in wired if c.end_connector != "rotor_angle_deg"]
system = SystemDescription([*specs, FmuSpec("ekf_free", EKF, ekf)], wired + free)
NAMES = ("nis", "q1_est_ml_min", "q2_est_ml_min")
with Master(system) as master:
    run = master.run(stop_time=DURATION, step_size=1e-3, order=["plant", "ekf", "ekf_free"],
                     record=[f"{i}.{n}" for i in ("ekf", "ekf_free") for n in NAMES])
columns = run.recorder.arrays()
time = columns["time"]
result = {"wired": sorted(c.end_connector for c in wired)}
for instance in ("ekf", "ekf_free"):
    late = time > DURATION - 1.5
    result[instance] = {
        "nis": float(columns[f"{instance}.nis"][time > 2.0].mean()),
        "error_pct": [100.0 * (float(columns[f"{instance}.q{b}_est_ml_min"][late].mean()) - q) / q
                      for b, q in ((1, Q1), (2, Q2))],
    }
"""


@pytest.fixture(scope="module")
def keyphasor_run(built_fmus):
    head = (
        f"PLANT = {str(built_fmus / 'RotorBearingPlant.fmu')!r}\n"
        f"EKF = {str(built_fmus / 'OilFlowEKF.fmu')!r}\n"
        f"Q1, Q2 = {TRUTH}\nDURATION = {DURATION_S}\n"
    )
    return run_json(head + CODE, timeout=900)


@pytest.mark.slow
def test_the_keyphasor_connected_by_name_keeps_the_estimate_right_off_the_nominal_speed(keyphasor_run):
    assert "rotor_angle_deg" in keyphasor_run["wired"]
    connected = keyphasor_run["ekf"]
    # consistent (4 channels: mean NIS 4; library test: 4.06) and right (library test: +0.09 / +0.22 %)
    assert connected["nis"] == pytest.approx(4.0, rel=0.15), connected
    assert max(abs(e) for e in connected["error_pct"]) < 1.0, connected


@pytest.mark.slow
def test_without_the_keyphasor_the_slipping_phase_shows_in_the_nis_and_the_estimate(keyphasor_run):
    free = keyphasor_run["ekf_free"]
    # library test: NIS 53, errors +5.5 / +2.2 %
    assert free["nis"] > 4.0 * keyphasor_run["ekf"]["nis"], free
    assert max(abs(e) for e in free["error_pct"]) > 2.0, free
