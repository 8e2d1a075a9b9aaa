"""A keyphasor keeps the estimator's unbalance phase when it is not given the speed (issue 13 item 3).

The plant (full-order Newmark model on the dimensionless table) turns at 75.6 Hz; the estimator is told the
nominal 75 Hz. Without a keyphasor its unbalance phase, the integral of that speed, slips by 0.6 rev/s and
its 1x orbit soon has the wrong phase: the NIS grows far above its 4 channels. With the plant's rotor angle
(``OilFlowEKF.step(..., rotor_angle_rad=)``: the angle at the previous sample, where the prediction starts)
the phase is right at every sample and the filter stays consistent.
"""

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
TRUTH = np.array([0.8, 1.0]) * QN
PLANT_HZ, TOLD_HZ = 75.6, 75.0
STEPS = 4000


@pytest.fixture(scope="module")
def record():
    """(measured (K, 4) [m], rotor angle at each sample (K,) [rad]) of the plant at PLANT_HZ."""
    system = operating_system(MACHINE, PLANT_HZ, MACHINE.bearing.viscosity_pa_s)
    plant = RotorBearingPlant(system, 1e-3, None, 1e-6, 5, initial_flowrates_m3_s=tuple(TRUTH))
    measured, angle = np.empty((STEPS, 4)), np.empty(STEPS)
    for k in range(STEPS):
        measured[k] = plant.step(tuple(TRUTH)).measured_position_m
        angle[k] = plant.rotor_angle_rad
    return measured, angle


@pytest.fixture(scope="module")
def model():
    return build_operating_model(load_system(reduced=True), MACHINE)


def _run(model, measured, angle):
    ekf = OilFlowEKF(model, EKFConfig.recommended(first_sample_time_s=1e-3))
    nis, q = np.empty(STEPS), np.empty((STEPS, 2))
    for k in range(STEPS):
        keyphasor = None if angle is None or k == 0 else float(angle[k - 1])
        report = ekf.step(measured[k], TOLD_HZ, T0, keyphasor)
        nis[k], q[k] = report.nis, report.q_m3_s
    last = slice(STEPS - 1500, None)
    return nis[2000:].mean(), 100.0 * (q[last].mean(axis=0) - TRUTH) / TRUTH


def test_the_keyphasor_keeps_the_phase_when_the_speed_is_not_given(model, record):
    measured, angle = record
    nis_keyed, error_keyed = _run(model, measured, angle)
    nis_free, _ = _run(model, measured, None)
    assert nis_keyed < 6.0, nis_keyed  # 4 channels: consistent
    assert np.abs(error_keyed).max() < 1.0, error_keyed
    assert nis_free > 3.0 * nis_keyed, (nis_free, nis_keyed)
