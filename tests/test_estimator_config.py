"""Configuration and model-contract validation of the oil-flow EKF: every bad value names its field."""

from __future__ import annotations

import numpy as np
import pytest
from fixtures.toy_model import ToyRotor

from oilwatch.estimator.alarm_config import AlarmConfig
from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import ML_MIN, EKFConfig
from oilwatch.estimator.model import AugmentedModel
from oilwatch.models.validation import InputError


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("noise_std_m", 0.0),
        ("noise_std_m", float("nan")),
        ("velocity_noise", "both"),
        ("initial_state", "random"),
        ("displacement_process_std_m", -1e-6),
        ("velocity_process_std_m_s", float("inf")),
        ("flowrate_process_std_m3_s", -1.0),
        ("q_nominal_m3_s", 0.0),
        ("q_nominal_m3_s", (1e-5, -1e-5)),
        ("q_nominal_m3_s", (1e-5, 1e-5, 1e-5)),
        ("q_initial_m3_s", -1.0),
        ("q_initial_m3_s", (1e-5, 1e-5, 1e-5)),
        ("q_initial_m3_s", "lots"),
        ("initial_flowrate_std_m3_s", -1.0),
        ("initial_flowrate_std_m3_s", (1e-6, 0.0)),
        ("gate_tail_probability", 0.7),
        ("alarm", {"on_fraction": 0.9}),
    ],
)
def test_bad_config_field_is_named(field, value):
    with pytest.raises(InputError, match=field):
        EKFConfig(**{field: value})


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("on_fraction", 0.0),
        ("off_fraction", 2.0),
        ("confidence_z", -1.0),
        ("hold_on_s", -0.1),
        ("hold_off_s", float("nan")),
    ],
)
def test_bad_alarm_field_is_named(field, value):
    with pytest.raises(InputError, match=field):
        AlarmConfig(**{field: value})


def test_alarm_hysteresis_order_is_enforced():
    with pytest.raises(InputError, match="off_fraction"):
        AlarmConfig(on_fraction=0.9, off_fraction=0.85)


def test_defaults_are_the_papers():
    config = EKFConfig()
    assert config.displacement_process_std_m == 10e-6
    assert config.velocity_process_std_m_s == 10e-6
    assert config.flowrate_process_std_m3_s == pytest.approx(0.1 * ML_MIN)
    assert config.q_initial_m3_s is None and config.q_nominal_m3_s is None  # machine facts: from the model
    resolved = config.for_model(ToyRotor())
    assert resolved.q_initial_pair() == pytest.approx((596.3 * ML_MIN, 596.3 * ML_MIN))
    assert resolved.q_nominal_pair() == pytest.approx((596.3 * ML_MIN, 596.3 * ML_MIN))
    assert resolved.initial_flowrate_std_pair() == pytest.approx((0.25 * 596.3 * ML_MIN,) * 2)
    assert config.initial_state == "zero"


def test_recommended_velocity_noise_follows_the_model_speed():
    config = EKFConfig.recommended().for_model(ToyRotor())
    assert config.velocity_process_std_m_s == pytest.approx(0.1e-6 * 2 * 3.141592653589793 * 75.0)
    assert EKFConfig.recommended(speed_hz=80.0).velocity_process_std_m_s == pytest.approx(
        0.1e-6 * 2 * 3.141592653589793 * 80.0
    )


def test_estimator_parameters_are_generated_from_the_config_classes():
    from oilwatch.estimator.boundary_parameters import ESTIMATOR_PARAMETERS, config_from_parameters

    by_name = {p.name: p for p in ESTIMATOR_PARAMETERS}
    assert by_name["alarm_on_fraction"].default == AlarmConfig().on_fraction
    assert (by_name["alarm_hold_off_s"].low, by_name["alarm_hold_off_s"].high) == (0.0, 600.0)
    assert by_name["q_std_displacement_um"].default == pytest.approx(0.1)
    config = config_from_parameters({"alarm_hold_on_s": 0.5, "noise_um": 2.0})
    assert config.alarm.hold_on_s == 0.5 and config.noise_std_m == pytest.approx(2e-6)


def test_toy_satisfies_the_protocol():
    assert isinstance(ToyRotor(), AugmentedModel)


def test_initial_flowrate_outside_the_table_is_refused():
    with pytest.raises(InputError, match="q_initial_m3_s"):
        OilFlowEKF(ToyRotor(), EKFConfig(q_initial_m3_s=900.0 * ML_MIN))


def test_model_with_wrong_output_shape_is_refused():
    model = ToyRotor()
    model.output_matrix = np.eye(4, 7)
    with pytest.raises(InputError, match="output_matrix"):
        OilFlowEKF(model)


def test_static_start_needs_a_model_with_static_state():
    class NoStatic:
        n_states = 2
        dt_s = 1e-3
        output_matrix = np.zeros((4, 2))
        velocity_output_matrix = np.zeros((4, 2))
        bearing_flowrate_bounds_m3_s = np.array([(1e-6, 1e-4), (1e-6, 1e-4)])
        nominal_flowrates_m3_s = (5e-5, 5e-5)

        def transition(self, state, flowrate_m3_s, step):
            return state, np.eye(2), np.zeros((2, 2))

        def physical_covariance(self, displacement_std_m, velocity_std_m_s):
            return np.diag([displacement_std_m**2, velocity_std_m_s**2])

    OilFlowEKF(NoStatic())
    with pytest.raises(InputError, match="initial_state"):
        OilFlowEKF(NoStatic(), EKFConfig(initial_state="static"))


def test_measurement_of_wrong_shape_is_refused():
    ekf = OilFlowEKF(ToyRotor())
    with pytest.raises(InputError, match="displacement_m"):
        ekf.step(np.zeros(3))
