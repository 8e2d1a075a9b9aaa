"""The RotorBearingPlant FMU (issue 5), driven through fmpy in fresh processes.

The FMU is built once per session by ``build.py`` in its own process (``built_fmus``); every check loads it in
another fresh process, so none of this runs in the process that built it.
"""

import numpy as np
import pytest
from fixtures.fmu_subprocess import run_json

HEADER = """
import numpy as np
from oilwatch.cosim import FmuSpec, Master, SystemDescription
FMU = {fmu!r}
ML = 1e-6 / 60.0

def simulate(parameters, stop, record):
    system = SystemDescription([FmuSpec("plant", FMU, parameters)], connections=[])
    with Master(system) as master:
        result = master.run(stop_time=stop, step_size=1e-3, record=["plant." + r for r in record])
    arrays = result.recorder.arrays()
    return arrays["time"], {{r: arrays["plant." + r] for r in record}}
"""
TRUE = ["x1_true_um", "y1_true_um", "x2_true_um", "y2_true_um"]
MEASURED = ["x1_um", "y1_um", "x2_um", "y2_um"]


@pytest.fixture(scope="module")
def fmu(built_fmus):
    return str(built_fmus / "RotorBearingPlant.fmu")


def _run(fmu, body, timeout=300):
    return run_json(HEADER.format(fmu=fmu) + body, timeout)


def test_fmpy_validate_reports_no_problem_and_every_variable_has_unit_and_description(fmu):
    result = _run(
        fmu,
        """
from fmpy import read_model_description
from fmpy.validation import validate_fmu
md = read_model_description(FMU)
result = {
    "problems": validate_fmu(FMU),
    "missing": [v.name for v in md.modelVariables
                if not v.description or (v.type == "Real" and not v.unit)],
    "experiment": [md.defaultExperiment.stopTime, md.defaultExperiment.stepSize],
}
""",
    )
    assert result["problems"] == []
    assert result["missing"] == []
    assert [float(v) for v in result["experiment"]] == [20.0, 0.001]


def test_orbit_after_the_transient_matches_the_harmonic_unbalance_response(fmu):
    result = _run(
        fmu,
        """
from oilwatch.models.system.factory import load_system
q = (0.9 * 596.3 * ML, 0.85 * 596.3 * ML)
params = {"noise_um": 0.0, "q1_initial_ml_min": 0.9 * 596.3, "q1_final_ml_min": 0.9 * 596.3,
          "q2_initial_ml_min": 0.85 * 596.3, "q2_final_ml_min": 0.85 * 596.3}
t, out = simulate(params, 1.0, ["x1_true_um", "y1_true_um", "x2_true_um", "y2_true_um", "x1_um"])
system = load_system(reduced=False)
static = system.bearing_positions(system.static_coordinates(q)).ravel()
amplitude = system.bearing_positions(system.unbalance_coordinates(q)).ravel()
tail = slice(-200, None)
expected = static + (amplitude[None, :] * np.exp(1j * system.omega_rad_s * t[tail])[:, None]).real
got = np.column_stack([out[k][tail] for k in ("x1_true_um", "y1_true_um", "x2_true_um", "y2_true_um")]) * 1e-6
result = {"error": float(np.abs(got - expected).max()), "orbit": float(np.abs(amplitude).max()),
          "noise_free": float(np.abs(out["x1_um"] - out["x1_true_um"]).max())}
""",
    )
    assert result["error"] < 0.01 * result["orbit"]
    assert result["noise_free"] == 0.0


def test_measurement_noise_is_white_with_the_requested_std_and_seeded(fmu):
    result = _run(
        fmu,
        """
def noise(seed):
    t, out = simulate({"noise_um": 2.0, "seed": seed}, 10.0, ["x1_um", "y1_um", "x2_um", "y2_um",
                      "x1_true_um", "y1_true_um", "x2_true_um", "y2_true_um"])
    return np.concatenate([out[m] - out[m[:2] + "_true_um"] for m in ("x1_um", "y1_um", "x2_um", "y2_um")])
a, b, c = noise(3), noise(3), noise(4)
lag1 = float(np.corrcoef(a[:-1], a[1:])[0, 1])
result = {"mean": float(a.mean()), "std": float(a.std()), "same_seed": bool(np.array_equal(a, b)),
          "other_seed": bool(np.array_equal(a, c)), "lag1": lag1, "n": int(a.size)}
""",
    )
    assert abs(result["mean"]) < 0.05  # 4 x 10001 samples: the mean's std is 0.01 um
    assert abs(result["std"] / 2.0 - 1.0) < 0.05
    assert abs(result["lag1"]) < 0.05
    assert result["same_seed"] and not result["other_seed"]


def test_flowrate_outputs_follow_the_sigmoid_formula_exactly(fmu):
    result = _run(
        fmu,
        """
params = {"q1_final_ml_min": 447.2, "q2_initial_ml_min": 596.3, "q2_final_ml_min": 745.4,
          "fault_time_s": 1.0, "fault_duration_s": 0.4, "noise_um": 0.0}
t, out = simulate(params, 2.0, ["q1_ml_min", "q2_ml_min"])
tau = 0.4 / (2.0 * np.log(9.0))
sigmoid = 1.0 / (1.0 + np.exp(-(t - 1.0) / tau))
result = {"q1": float(np.abs(out["q1_ml_min"] - (596.3 + (447.2 - 596.3) * sigmoid)).max()),
          "q2": float(np.abs(out["q2_ml_min"] - (596.3 + (745.4 - 596.3) * sigmoid)).max())}
""",
    )
    assert result["q1"] < 1e-9 and result["q2"] < 1e-9


def test_a_flowrate_step_moves_the_static_position_by_the_table_prediction(fmu):
    result = _run(
        fmu,
        """
from oilwatch.models.system.factory import load_system
params = {"q1_final_ml_min": 0.8 * 596.3, "fault_time_s": 0.5, "fault_duration_s": 0.02, "noise_um": 0.0}
t, out = simulate(params, 3.0, TRUE_NAMES)
revolutions = 40  # 3 revolutions at 75 Hz: the orbit averages out
before = np.array([out[k][400:440].mean() for k in TRUE_NAMES]) * 1e-6
after = np.array([out[k][-revolutions:].mean() for k in TRUE_NAMES]) * 1e-6
system = load_system(reduced=False)
start = system.bearing_positions(system.static_coordinates((596.3 * ML, 596.3 * ML))).ravel()
end = system.bearing_positions(system.static_coordinates((0.8 * 596.3 * ML, 596.3 * ML))).ravel()
result = {"shift": (after - before).tolist(), "predicted": (end - start).tolist()}
""".replace("TRUE_NAMES", repr(TRUE)),
    )
    shift, predicted = result["shift"], result["predicted"]
    assert max(abs(p) for p in predicted) > 0.5e-6  # the step moves the journal by a measurable amount
    assert max(abs(s - p) for s, p in zip(shift, predicted, strict=True)) < 0.02e-6


def test_flow_source_inputs_drive_the_flowrates(fmu):
    result = _run(
        fmu,
        """
t, out = simulate({"flow_source": 1, "q1_in_ml_min": 500.0, "q2_in_ml_min": 650.0}, 0.2,
                  ["q1_ml_min", "q2_ml_min"])
result = [float(out["q1_ml_min"][-1]), float(out["q2_ml_min"][-1])]
""",
    )
    assert result == [500.0, 650.0]


def test_state_save_and_restore_is_bit_identical(fmu):
    result = _run(
        fmu,
        """
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
md = read_model_description(FMU)
refs = {v.name: v.valueReference for v in md.modelVariables}
slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(FMU), modelIdentifier="RotorBearingPlant",
                  instanceName="plant")
slave.instantiate()
slave.setupExperiment(startTime=0.0)
slave.enterInitializationMode()
# A drop in progress at the save point, so the integrator's sub-step path and noise are both exercised.
slave.setReal([refs["q1_final_ml_min"], refs["fault_time_s"], refs["fault_duration_s"]], [450.0, 5.2, 0.5])
slave.exitInitializationMode()
outputs = [refs[n] for n in MEASURED + TRUE + ["q1_ml_min"]]
for k in range(5000):
    slave.doStep(k * 1e-3, 1e-3)
state = slave.getFMUstate()
def run_to_6_s():
    rows = []
    for k in range(5000, 6000):
        slave.doStep(k * 1e-3, 1e-3)
        rows.append(slave.getReal(outputs))
    return rows
first = run_to_6_s()
slave.setFMUstate(state)
second = run_to_6_s()
slave.freeFMUstate(state)
slave.terminate()
slave.freeInstance()
result = {"identical": first == second, "moved": first[0] != first[-1]}
""".replace("MEASURED", repr(MEASURED)).replace("TRUE", repr(TRUE)),
    )
    assert result == {"identical": True, "moved": True}


@pytest.mark.parametrize(
    ("parameter", "value", "named"),
    [
        ("q1_initial_ml_min", -5.0, "q1_initial_ml_min"),
        ("noise_um", -1.0, "noise_um"),
        ("speed_hz", 60.0, "speed_hz"),
        ("q2_final_ml_min", 5000.0, "q2_final_ml_min"),
        ("machine_file", "/nonexistent/machine.toml", "machine_file"),
    ],
)
def test_bad_parameter_fails_initialization_naming_it_without_crashing_the_host(fmu, parameter, value, named):
    result = _run(
        fmu,
        f"""
from oilwatch.cosim import SlaveError
try:
    simulate({{{parameter!r}: {value!r}}}, 0.01, ["x1_um"])
    result = {{"raised": None}}
except SlaveError as error:
    result = {{"raised": str(error) + " " + " ".join(map(str, error.log))}}
""",
    )
    assert result["raised"] is not None
    assert named in result["raised"]


def test_the_one_sided_threshold_reaches_the_plants_structure(fmu):
    """threshold_one_sided = 1 is the structure's flag: with another bearing length it is refused as the
    library refuses it (tests/test_plant_structure.py checks its film coefficients)."""
    result = _run(
        fmu,
        """
from oilwatch.cosim import SlaveError
def refused(parameters):
    try:
        simulate(parameters, 0.002, ["x1_um"])
    except SlaveError as error:
        return str(error) + " " + " ".join(map(str, error.log))
result = {"alone": refused({"threshold_one_sided": 1}),
          "with length": refused({"threshold_one_sided": 1, "length_factor": 1.05})}
""",
    )
    assert result["alone"] is None
    assert "threshold_one_sided needs length_factor 1" in result["with length"]


def test_operating_point_inputs_and_measurement_chain_parameters(fmu):
    # bearing_table = 1: the speed input ramps down 2 Hz in 0.2 s; probe x1 dies at 0.1 s; y1 has a 5 um
    # zero offset; the new outputs (film state, rotor angle) are published. Then bearing_table = 0 refuses
    # a speed change by name.
    result = _run(
        fmu,
        """
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
md = read_model_description(FMU)
vr = {v.name: v.valueReference for v in md.modelVariables}
folder = extract(FMU)

def run(bearing_table, steps):
    slave = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="plant%d" % bearing_table)
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.setReal([vr["noise_um"], vr["x1_fault_time_s"], vr["y1_offset_um"]], [0.0, 0.1, 5.0])
    slave.setInteger([vr["bearing_table"], vr["x1_fault"]], [bearing_table, 1])
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    names = ["x1_um", "y1_um", "y1_true_um", "rotor_angle_deg", "eccentricity_ratio1", "h_min1_um"]
    rows, speeds, error = [], [], None
    try:
        for k in range(steps):
            speed = 75.0 - 0.01 * (k + 1)
            speeds.append(speed)
            slave.setReal([vr["speed_hz"]], [speed])
            slave.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
            rows.append(slave.getReal([vr[n] for n in names]))
    except Exception as exc:
        error = str(exc)
    return np.array(rows), speeds, error

rows, speeds, error = run(1, 200)
angle = (360.0 * 1e-3 * np.sum(speeds)) % 360.0
result = {
    "error": error,
    "x1_dead": bool(np.isnan(rows[100:, 0]).all() and np.isfinite(rows[:99, 0]).all()),
    "offset": float(np.max(np.abs(rows[:, 1] - rows[:, 2] - 5.0))),
    "angle": [float(rows[-1, 3]), float(angle)],
    "film": float(np.max(np.abs(rows[:, 5] - 120.0 * (1 - rows[:, 4])))),
    "ratio": float(rows[-1, 4]),
    "refused": run(0, 3)[2],
}
""",
    )
    assert result["error"] is None
    assert result["x1_dead"]
    assert result["offset"] < 1e-9
    assert result["angle"][0] == pytest.approx(result["angle"][1], abs=1e-6)
    assert result["film"] < 1e-9 and 0.05 < result["ratio"] < 0.3
    assert result["refused"] is not None


def test_master_input_signals_drive_the_speed(fmu):
    result = _run(
        fmu,
        """
from oilwatch.cosim.errors import SystemDescriptionError
system = SystemDescription([FmuSpec("plant", FMU, {"bearing_table": 1, "noise_um": 0.0})], connections=[])
with Master(system) as master:
    run = master.run(stop_time=0.05, step_size=1e-3, record=["plant.rotor_angle_deg"],
                     input_signals={"plant.speed_hz": lambda t: 75.0 - 20.0 * t})
    try:
        master.run(stop_time=0.01, step_size=1e-3, input_signals={"plant.noise_um": lambda t: 1.0})
        refused = None
    except SystemDescriptionError as error:
        refused = str(error)
angle = run.recorder.arrays()["plant.rotor_angle_deg"][-1]
expected = (360.0 * 1e-3 * sum(75.0 - 20.0 * k * 1e-3 for k in range(50))) % 360.0
result = {"angle": [float(angle), float(expected)], "refused": refused}
""",
    )
    assert result["angle"][0] == pytest.approx(result["angle"][1], abs=1e-6)
    assert "no input 'noise_um'" in result["refused"]


def test_the_structure_parameters_give_the_structural_plants_orbit(fmu):
    """Pedestals and a bow set through the FMU's parameters: its steady 1x orbit is the one of
    oilwatch.models.system.structure's plant with the same values, not the machine file's."""
    result = _run(
        fmu,
        """
import math
from oilwatch.models.machine import load_machine
from oilwatch.models.system.structure import PlantStructure, structural_system
parameters = {"noise_um": 0.0, "pedestal_mass_kg": 150.0, "pedestal_stiffness_n_m": 2e8,
              "pedestal_damping_n_s_m": 6.9e3, "bow_um": 10.0, "bow_phase_deg": 45.0}
names = ["x1_true_um", "y1_true_um", "x2_true_um", "y2_true_um"]
t, out = simulate(parameters, 0.2, names)
machine = load_machine(None)
system = structural_system(machine, PlantStructure(pedestal_mass_kg=150.0, pedestal_stiffness_n_m=2e8,
    pedestal_damping_n_s_m=6.9e3, bow_m=10e-6, bow_phase_rad=math.radians(45.0)))
q = tuple(machine.lubrication.nominal_flowrates_m3_s)
static = system.bearing_positions(system.static_coordinates(q)).ravel() * 1e6
orbit = system.bearing_positions(system.unbalance_coordinates(q)).ravel() * 1e6
expected = [(static[k] + (orbit[k] * np.exp(1j * system.omega_rad_s * t)).real).tolist() for k in range(4)]
result = {"fmu": [out[name].tolist() for name in names], "expected": expected}
""",
    )
    fmu_orbit, expected = np.array(result["fmu"]), np.array(result["expected"])
    assert np.abs(fmu_orbit - expected).max() < 0.02 * np.ptp(expected, axis=1).max()
