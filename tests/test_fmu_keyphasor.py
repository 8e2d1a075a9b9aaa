"""The keyphasor at FMU level: plant and estimator FMUs, the estimator's ``rotor_angle_deg`` connected to the
plant's output of the same name (issue 13 item 3; the library-level test is ``tests/test_keyphasor.py``).

The plant FMU turns at 75.6 Hz (``bearing_table = 1``, its ``speed_hz`` input); both estimator FMUs run
``bearing_table = 1`` and are told nothing of the speed, so they take the nominal 75 Hz. One is wired by the
master's same-name matching (``oilwatch.cosim.connections.same_name_connections``, as ``oilwatch run`` wires
it); the other has every one of those connections but the keyphasor, whose input stays at its start value -1
(not connected: the integral of the speed). Its unbalance phase then slips by 0.6 rev/s; the connected one
keeps the plant's phase at every sample. 4 s at 80 / 100 % flow, stepped by ``tests/test_ekf_fmu.py``'s
``cosimulate`` (plant first, then each filter on the plant's outputs of that step, as the master's
Gauss-Seidel order ``plant, ekf``). The run shares one fresh process with ``tests/test_fmu_runout.py``'s
(the ``probe_nuisance_cosims`` fixture of tests/conftest.py).
"""

from __future__ import annotations

import pytest

NOMINAL_ML_MIN = 596.3
TRUTH = (0.8 * NOMINAL_ML_MIN, 1.0 * NOMINAL_ML_MIN)
DURATION_S = 4.0

CODE = """
def keyphasor_cosim(plant_fmu, ekf_fmu, q1, q2, duration_s):
    from oilwatch.cosim.connections import same_name_connections
    flows = {f"q{b}_{s}_ml_min": q for b, q in ((1, q1), (2, q2)) for s in ("initial", "final")}
    reals = {"speed_hz": 75.6, "noise_um": 1.0, **flows}
    plant = load(plant_fmu, "plant", reals, {"bearing_table": 1, "seed": 5})
    variables = {name: read_model_description(path).modelVariables
                 for name, path in (("plant", plant_fmu), ("ekf", ekf_fmu))}
    wired = [c.end_connector for c in same_name_connections(variables) if c.end_element == "ekf"]
    free = [name for name in wired if name != "rotor_angle_deg"]
    # the paper preset (nuisances known): the keyphasor's phase alone
    settings = ({"noise_um": 1.0}, {"bearing_table": 1}, {"preset": "paper"})
    filters = {name: (*load(ekf_fmu, name, *settings), ports)
               for name, ports in (("ekf", wired), ("ekf_free", free))}
    steps = round(duration_s / 1e-3)
    result = {"wired": sorted(wired)}
    for name, rows in cosimulate(*plant, filters, steps, ["nis", "q1_est_ml_min", "q2_est_ml_min"]).items():
        table = np.array(rows)
        time = 1e-3 * np.arange(1, steps + 1)  # the filter's time after each step
        late = table[time > duration_s - 1.5]
        result[name] = {
            "nis": float(table[time > 2.0, 0].mean()),
            "error_pct": [100.0 * (float(late[:, b].mean()) - q) / q for b, q in ((1, q1), (2, q2))],
        }
    return result
"""


def call(built_fmus) -> str:
    """The line of the shared process's code that runs this co-simulation."""
    plant, ekf = str(built_fmus / "RotorBearingPlant.fmu"), str(built_fmus / "OilFlowEKF.fmu")
    return f"keyphasor = keyphasor_cosim({plant!r}, {ekf!r}, {TRUTH[0]!r}, {TRUTH[1]!r}, {DURATION_S!r})\n"


@pytest.fixture(scope="module")
def keyphasor_run(probe_nuisance_cosims):
    return probe_nuisance_cosims["keyphasor"]


@pytest.mark.slow
@pytest.mark.xdist_group("probe_nuisance_cosims")
def test_the_keyphasor_connected_by_name_keeps_the_estimate_right_off_the_nominal_speed(keyphasor_run):
    assert "rotor_angle_deg" in keyphasor_run["wired"]
    connected = keyphasor_run["ekf"]
    # consistent (4 channels: mean NIS 4; library test: 4.06) and right (library test: +0.09 / +0.22 %)
    assert connected["nis"] == pytest.approx(4.0, rel=0.15), connected
    assert max(abs(e) for e in connected["error_pct"]) < 1.0, connected


@pytest.mark.slow
@pytest.mark.xdist_group("probe_nuisance_cosims")
def test_without_the_keyphasor_the_slipping_phase_shows_in_the_nis_and_the_estimate(keyphasor_run):
    free = keyphasor_run["ekf_free"]
    # library test: NIS 53, errors +5.5 / +2.2 %
    assert free["nis"] > 4.0 * keyphasor_run["ekf"]["nis"], free
    assert max(abs(e) for e in free["error_pct"]) > 2.0, free
