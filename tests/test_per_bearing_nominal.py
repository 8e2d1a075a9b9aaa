"""Each bearing's own nominal supply flowrate: solved at the groove pressure with the bearing's own geometry
and load, or given per bearing in its ``[[bearings.override]]``; the estimator starts each bearing at its own
nominal and sets each bearing's alarm levels as fractions of it, and the estimator FMU's parameters are per
bearing."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from fixtures.second_bearing import NON_DRIVE_END
from fixtures.toy_model import NOMINAL_FLOWRATE_M3_S, ToyRotor, simulate

from oilwatch.estimator.alarm_config import AlarmConfig
from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.fmu_src.ekf_configuration import flowrates_ml_min
from oilwatch.models.bearing.equilibrium import static_equilibrium
from oilwatch.models.bearing.grid import PRODUCTION_MESH
from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S, SupplyPressure
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.validation import InputError

TURBINE = Path(__file__).resolve().parents[1] / "models" / "turbine.toml"


def machine_file(folder: Path, override: str = NON_DRIVE_END, flowrate_line: str | None = None) -> Path:
    """The bundled turbine with ``override`` after its [bearings] table and its ``[lubrication]
    nominal_flowrate_ml_min`` line replaced by ``flowrate_line`` (None: left out, so solved at 0.5 bar)."""
    text = TURBINE.read_text(encoding="utf-8")
    text, found = re.subn(
        r"(?m)^nominal_flowrate_ml_min = .*\n", "" if flowrate_line is None else flowrate_line + "\n", text
    )
    assert found == 1
    text = text.replace("\n[oil]\n", f"\n{override}\n[oil]\n", 1)
    path = folder / "two.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_each_bearings_nominal_is_its_own_steady_flow_at_the_groove_pressure(tmp_path):
    """(a) Without a flowrate in the file, each bearing's nominal is the steady supply flow at the 0.5 bar
    groove pressure of that bearing's geometry under its share of the weight: recomputed here from the
    turbine's bearing with bearing 2's dimensions put in by hand and the weight halved (load_split equal)."""
    machine = load_machine(machine_file(tmp_path))
    assert machine.lubrication.nominal_flowrates_computed == (True, True)
    turbine = load_machine(None)
    bearing_2 = dataclasses.replace(
        turbine.bearing,
        length_m=0.060,
        clearance_m=137.5e-6,
        groove_angle_rad=0.0,
        groove_circumferential_m=0.014,
        groove_axial_m=0.030,
    )
    load = Rotor.from_machine(turbine).total_mass_kg * turbine.gravity_m_s2 / 2.0
    expected = [
        static_equilibrium(bearing, load, 75.0, SupplyPressure(0.5e5), PRODUCTION_MESH).supply_flow_m3_s
        for bearing in (turbine.bearing, bearing_2)
    ]
    np.testing.assert_allclose(machine.lubrication.nominal_flowrates_m3_s, expected, rtol=1e-6)
    one, two = machine.lubrication.nominal_flowrates_m3_s * ML_MIN_PER_M3_S
    assert two > 1.5 * one  # the looser bearing 2 takes far more: bearing 1's nominal is not its
    with pytest.raises(InputError, match=r"have different nominal flowrates .*: the test runs every bearing"):
        machine.shared_nominal_flowrate_m3_s("the test")


def test_a_per_bearing_nominal_in_the_file_is_that_bearings(tmp_path):
    """(c) An override's nominal_flowrate_ml_min is its bearing's; the [lubrication] one stays the others',
    or without it the others' is solved at the groove pressure."""
    given = NON_DRIVE_END + "nominal_flowrate_ml_min = 480.0\n"
    machine = load_machine(machine_file(tmp_path, given, "nominal_flowrate_ml_min = 596.3"))
    assert list(machine.lubrication.nominal_flowrates_m3_s * ML_MIN_PER_M3_S) == pytest.approx([596.3, 480.0])
    assert machine.lubrication.nominal_flowrates_computed == (False, False)
    mixed = load_machine(machine_file(tmp_path, given))
    assert mixed.lubrication.nominal_flowrates_computed == (True, False)
    q1, q2 = mixed.lubrication.nominal_flowrates_m3_s * ML_MIN_PER_M3_S
    assert q2 == pytest.approx(480.0) and 598.0 < q1 < 622.0  # bearing 1's, solved as the turbine's
    only = "[[bearings.override]]\nnode = 20\nnominal_flowrate_ml_min = 500.0\n"
    alike = load_machine(machine_file(tmp_path, only, "nominal_flowrate_ml_min = 596.3"))
    assert not alike.bearings_differ  # a flowrate alone leaves the geometry shared


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("0.0", r"bearings\.override\[0\]\.nominal_flowrate_ml_min must be > 0 ml/min, got 0$"),
        ("true", r"bearings\.override\[0\]\.nominal_flowrate_ml_min must be a number, got True$"),
    ],
)
def test_a_bad_per_bearing_nominal_is_refused_in_one_line(tmp_path, value, message):
    """(c) The file's usual one-line error, naming the key and its allowed range."""
    path = machine_file(
        tmp_path, NON_DRIVE_END + f"nominal_flowrate_ml_min = {value}\n", "nominal_flowrate_ml_min = 596.3"
    )
    with pytest.raises(InputError) as error:
        load_machine(path)
    assert "\n" not in str(error.value)
    assert re.search(message, str(error.value)), error.value


def toy_of_nominals(second_fraction: float) -> ToyRotor:
    """The toy rotor whose bearing 2's nominal is ``second_fraction`` of bearing 1's (the toy's film is
    unchanged: only the reference of bearing 2's percentages moves)."""
    toy = ToyRotor()
    toy.nominal_flowrates_m3_s = np.array([1.0, second_fraction]) * NOMINAL_FLOWRATE_M3_S
    return toy


def test_the_filter_starts_each_bearing_at_its_own_nominal_and_alarms_on_its_own_levels():
    """(b) Start, scaling and alarm levels per bearing: bearing 2's nominal 80 % of bearing 1's."""
    toy = toy_of_nominals(0.8)
    nominal = toy.nominal_flowrates_m3_s
    ekf = OilFlowEKF(toy, EKFConfig.recommended())
    np.testing.assert_array_equal(ekf.flowrate_m3_s, nominal)
    np.testing.assert_array_equal(ekf.flowrate_std_m3_s, 0.25 * nominal)  # a quarter of each
    alarm = AlarmConfig()
    np.testing.assert_allclose(
        ekf.alarm.levels_m3_s, np.column_stack([alarm.on_fraction * nominal, alarm.off_fraction * nominal])
    )
    n = ekf.state_layout.n
    np.testing.assert_array_equal(ekf.get_state()["x"][n : n + 2], [1.0, 1.0])  # each in its own unit


def test_a_bearing_at_its_own_nominal_is_not_alarmed_however_small_beside_the_other():
    """(b) End to end on the toy: both bearings at their own nominals (bearing 2 at 80 % of bearing 1's
    flow) stay unalarmed; referred to bearing 1's nominal, as one machine-wide nominal did, bearing 2 would
    sit below the 90 % level and be alarmed for the whole run."""
    truth = np.array([1.0, 0.8]) * NOMINAL_FLOWRATE_M3_S
    own = toy_of_nominals(0.8)
    record = simulate(own, np.tile(truth, (3000, 1)), 1e-6, seed=5)
    trace = OilFlowEKF(own, EKFConfig.recommended()).run(record.displacement_m)
    assert not trace.starved.any()
    assert np.abs(trace.q_m3_s[-1000:] / truth - 1.0).max() < 0.02
    shared = OilFlowEKF(toy_of_nominals(1.0), EKFConfig.recommended()).run(record.displacement_m)
    assert shared.starved[-1000:, 1].all() and not shared.starved[:, 0].any()


def test_a_bad_per_bearing_nominal_in_the_configuration_is_refused():
    with pytest.raises(InputError, match=r"^EKFConfig\.q_nominal_m3_s must be one value or a pair, got 3"):
        EKFConfig(q_nominal_m3_s=(1e-5, 1e-5, 1e-5))
    with pytest.raises(InputError, match=r"^EKFConfig\.q_nominal_m3_s must be > 0"):
        EKFConfig(q_nominal_m3_s=(1e-5, -1e-5))
    toy = ToyRotor()
    high = toy.bearing_flowrate_bounds_m3_s[1][1]
    # the start, each bearing's nominal by default, must lie in its bearing's range
    with pytest.raises(
        InputError, match=r"^EKFConfig\.q_initial_m3_s of bearing 2 must lie in its table range"
    ):
        OilFlowEKF(toy, EKFConfig.recommended(q_nominal_m3_s=(NOMINAL_FLOWRATE_M3_S, 1.1 * high)))


def test_the_estimator_fmus_parameters_are_per_bearing():
    """q<b>_nominal_ml_min 0 is bearing b's nominal, q<b>_initial_ml_min 0 its nominal; each is checked
    against its own bearing's range, named as given."""
    nominal = np.array([596.3, 480.0])
    system = SimpleNamespace(
        nominal_flowrates_m3_s=nominal / ML_MIN_PER_M3_S,
        bearing_flowrate_bounds_m3_s=np.array([(300.0, 900.0), (250.0, 700.0)]) / ML_MIN_PER_M3_S,
    )
    unset = {f"q{b}_{kind}_ml_min": 0.0 for b in (1, 2) for kind in ("nominal", "initial")}
    found = flowrates_ml_min(SimpleNamespace(**unset), system)
    assert np.allclose(found, [(596.3, 480.0)] * 2, rtol=1e-12)
    given = flowrates_ml_min(SimpleNamespace(**{**unset, "q2_nominal_ml_min": 500.0}), system)
    assert np.allclose(given, [(596.3, 500.0)] * 2, rtol=1e-12)
    with pytest.raises(InputError) as error:
        flowrates_ml_min(SimpleNamespace(**{**unset, "q2_nominal_ml_min": 800.0}), system)
    assert str(error.value) == (
        "q2_nominal_ml_min must lie in bearing 2's coefficient table range [250.0, 700.0] ml/min, got "
        "800 ml/min"
    )
