"""The operating model's state across the filter's reset, and when a measured speed takes effect.

* ``OilFlowEKF.reset()`` returns the operating model to the state of a model just built: its correction
  centre does not survive, so a record's estimates do not depend on what the filter ran before.
* The unbalance phase is the integral of the measured speed with the plant's convention: the speed given
  with sample k is the one held over the period that ends at sample k, and the model's rotor angle equals
  the plant's at every sample, through a 72 -> 78 Hz step (a period late would be 2.2 deg behind after it).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.operating_model import build_operating_model
from oilwatch.models.system.operating_point import operating_system
from oilwatch.models.system.plant import RotorBearingPlant

MACHINE = load_machine()
QN = MACHINE.shared_nominal_flowrate_m3_s("this test")
T0 = MACHINE.nominal_oil_temperature_c
STEPS = 300
CONFIG = EKFConfig.recommended(first_sample_time_s=1e-3)


@pytest.fixture(scope="module")
def system():
    return load_system(reduced=True)


@pytest.fixture(scope="module")
def plant_run():
    """(measured (K, 4) [m], speed given with each sample (K,) [Hz], plant rotor angle at each sample (K,))
    of the plant through a 72 -> 78 Hz step at sample 150 (the oil at its nominal temperature)."""
    q = (0.9 * QN, 0.9 * QN)
    speed = np.where(np.arange(STEPS) < 150, 72.0, 78.0)
    plant_system = operating_system(MACHINE, 72.0, MACHINE.oil.dynamic_viscosity_pa_s(T0))
    plant = RotorBearingPlant(
        plant_system, 1e-3, None, 1e-6, 2, initial_flowrates_m3_s=q, oil=MACHINE.oil, oil_temperature_c=T0
    )
    measured, angle = np.empty((STEPS, 4)), np.empty(STEPS)
    for k in range(STEPS):
        measured[k] = plant.step(q, speed_hz=float(speed[k]), oil_temperature_c=T0).measured_position_m
        angle[k] = plant.rotor_angle_rad
    return measured, speed, angle


def _estimates(ekf, measured, speed, angle_of=None):
    q, angles = np.empty((STEPS, 2)), np.empty(STEPS)
    for k in range(STEPS):
        q[k] = ekf.step(measured[k], float(speed[k]), T0 + 0.01 * k).q_m3_s  # warming 10 degC/s
        angles[k] = ekf.model.rotor_angle_rad(k + 1)  # t_k = k dt, first sample at 1 ms
    return q, angles


def test_the_model_turns_the_unbalance_with_the_plants_speed_in_the_same_period(system, plant_run):
    measured, speed, plant_angle = plant_run
    ekf = OilFlowEKF(build_operating_model(system, MACHINE), CONFIG)
    _, angles = _estimates(ekf, measured, speed)
    np.testing.assert_allclose(angles, plant_angle, rtol=0.0, atol=1e-9)
    late = np.cumsum(2.0 * math.pi * np.concatenate([[72.0], speed[:-1]]) * 1e-3)
    assert math.degrees(plant_angle[-1] - late[-1]) == pytest.approx(2.16, abs=0.01)  # what the test tells


@pytest.mark.slow  # a long record; the module's other tests keep it in the fast tier
def test_reset_leaves_no_correction_centre_behind(system, plant_run):
    measured, speed, _ = plant_run
    used = OilFlowEKF(build_operating_model(system, MACHINE), CONFIG)
    first, _ = _estimates(used, measured, speed)
    assert used.model.get_operating_state()["centre"].size == 5
    used.reset()
    assert used.model.get_operating_state()["centre"].size == 0
    again, _ = _estimates(used, measured, speed[::-1])  # another record after the reset
    fresh, _ = _estimates(OilFlowEKF(build_operating_model(system, MACHINE), CONFIG), measured, speed[::-1])
    np.testing.assert_array_equal(again, fresh)
    assert not np.array_equal(again, first)
