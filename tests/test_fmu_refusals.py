"""No input accepted and ignored by the FMUs (slow: the real FMUs): a plant flowrate input that is NaN,
negative or absurd is refused at the step (fmi2Error naming it), not held at nominal; a flowrate input set
while the schedule drives the flowrates is refused at initialization; fmi2DoStep before initialization is
fmi2Error naming the state; a garbage FMU state is refused with a message; q2_nominal_ml_min out of the table
is named as given; a parameter above its physical maximum (noise_um = 1e30) is refused naming it.
(``--set plant.q1_in_ml_min=1`` through ``oilwatch run``: test_misuse.)"""

from __future__ import annotations

import pytest
from fixtures.fmu_subprocess import run_json
from test_fmi_slave_behaviour import PRELUDE

pytestmark = pytest.mark.slow


def _case(built_fmus, body: str) -> dict:
    return run_json(
        PRELUDE
        + f"""
FOLDER = {str(built_fmus)!r}
def attempt(call):
    LOG.clear()
    try:
        call()
        return {{"status": 0, "log": list(LOG)}}
    except FMICallException as error:
        return {{"status": error.status, "log": list(LOG)}}
{body}
""",
        timeout=300,
    )


def _errors(outcome: dict) -> list[str]:
    return [message for status, message in outcome["log"] if status >= 3]


@pytest.mark.parametrize("value", ["float('nan')", "-5.0", "1e6"])
def test_a_plant_flowrate_input_out_of_range_is_refused_at_the_step(built_fmus, value):
    result = _case(
        built_fmus,
        f"""
plant, vr = load(FOLDER + "/RotorBearingPlant.fmu")
init(plant, vr, integers={{"flow_source": 1}})
plant.doStep(0.0, 1e-3)
plant.setReal([vr["q1_in_ml_min"]], [{value}])
result = attempt(lambda: plant.doStep(1e-3, 1e-3))
""",
    )
    assert result["status"] == 3, result  # fmi2Error, not OK with the nominal held
    assert any("q1_in_ml_min must be a flowrate in [0, 100000] ml/min" in m for m in _errors(result)), result


def test_wrong_state_garbage_state_ignored_input_and_misnamed_nominal(built_fmus):
    result = _case(
        built_fmus,
        """
plant, vr = load(FOLDER + "/RotorBearingPlant.fmu", "early")
early = attempt(lambda: plant.doStep(0.0, 1e-3))
plant, vr = load(FOLDER + "/RotorBearingPlant.fmu", "garbage")
init(plant, vr)
garbage = attempt(lambda: plant.deSerializeFMUstate(b"garbage bytes, not a state"))
plant, vr = load(FOLDER + "/RotorBearingPlant.fmu", "ignored")
ignored = attempt(lambda: init(plant, vr, {"q1_in_ml_min": 1.0}))
ekf, vr = load(FOLDER + "/OilFlowEKF.fmu", "nominal")
nominal = attempt(lambda: init(ekf, vr, {"q2_nominal_ml_min": 1e4}))
plant, vr = load(FOLDER + "/RotorBearingPlant.fmu", "noise")
noise = attempt(lambda: init(plant, vr, {"noise_um": 1e30}))
result = {"early": early, "garbage": garbage, "ignored": ignored, "nominal": nominal, "noise": noise}
""",
    )
    assert result["early"]["status"] == 3
    assert any("fmi2DoStep called before fmi2ExitInitializationMode" in m for m in _errors(result["early"]))
    assert result["garbage"]["status"] >= 3  # pythonfmu's static call: fatal, but with the reason
    assert any("are not a serialized state of this FMU" in m for m in _errors(result["garbage"])), result
    assert result["ignored"]["status"] == 3
    assert any("q1_in_ml_min = 1.0 is ignored while flow_source = 0" in m for m in _errors(result["ignored"]))
    assert result["nominal"]["status"] == 3
    named = [m for m in _errors(result["nominal"]) if m.startswith("nominal: q2_nominal_ml_min must lie in")]
    assert named, result
    assert result["noise"]["status"] == 3
    refused = [m for m in _errors(result["noise"]) if "noise_um must lie in [0, 1000] um, got 1e+30 um" in m]
    assert refused, result
