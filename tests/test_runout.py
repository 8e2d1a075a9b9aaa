"""Slow-roll runout compensation (estimator/runout.py, robustness/slow_roll.py, oilwatch baseline)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from oilwatch.cli import main
from oilwatch.estimator.baseline import load_runout
from oilwatch.estimator.runout import RunoutCompensation, SlowRollVectors, fit_slow_roll
from oilwatch.models.system.measurement import MeasurementChain, ProbeErrors
from oilwatch.models.validation import InputError
from oilwatch.robustness.slow_roll import slow_roll_record

CLEARANCES_M = (120e-6, 120e-6)
ONCE_UM = (2.0, 1.5, 0.7, 2.4)
ONCE_PHASE_RAD = (0.3, -2.0, 1.1, 2.9)
TWICE_UM = (1.0, 0.4, 1.2, 0.8)
TWICE_PHASE_RAD = (-0.5, 0.8, 3.0, -1.7)


def _chain(noise_um: float = 1.0, sensitivity: float = 0.0) -> MeasurementChain:
    probes = tuple(
        ProbeErrors(
            zero_offset_m=10e-6 * (k - 1.5),
            sensitivity_error=sensitivity,
            runout_1x_m=ONCE_UM[k] * 1e-6,
            runout_1x_phase_rad=ONCE_PHASE_RAD[k],
            runout_2x_m=TWICE_UM[k] * 1e-6,
            runout_2x_phase_rad=TWICE_PHASE_RAD[k],
        )
        for k in range(4)
    )
    return MeasurementChain(probes, math.radians(45.0), noise_um * 1e-6)


def _truth(sensitivity: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    scale = 1.0 + sensitivity
    once = scale * np.array(ONCE_UM) * 1e-6 * np.exp(1j * np.array(ONCE_PHASE_RAD))
    twice = scale * np.array(TWICE_UM) * 1e-6 * np.exp(1j * np.array(TWICE_PHASE_RAD))
    return once, twice


def test_the_slow_roll_fit_recovers_the_chains_runout_within_its_std():
    sensitivity = 0.04  # the probe reads its runout mis-scaled too: the vectors are what it reads
    times, signals, theta = slow_roll_record(_chain(1.0, sensitivity), CLEARANCES_M, 75.0, 20.0, 1e-3, seed=3)
    vectors = fit_slow_roll(times, signals, theta)
    once, twice = _truth(sensitivity)
    # the std of each component of a least-squares sinusoid fit: sigma sqrt(2 / N) (N samples)
    expected_std = 1e-6 * math.sqrt(2.0 / len(times))
    for fitted, std, truth in (
        (vectors.once_m, vectors.once_std_m, once),
        (vectors.twice_m, vectors.twice_std_m, twice),
    ):
        assert np.allclose(std, expected_std, rtol=0.1)
        error = np.asarray(fitted) - truth
        z = np.concatenate([error.real, error.imag]) / np.concatenate([std, std])
        assert np.all(np.abs(z) < 4.0)  # 8 components each
        assert (
            0.2 < float(np.mean(z**2)) < 3.0
        )  # the stds are the errors' size, neither far too small nor large


def test_compensation_removes_the_runout_at_each_samples_rotor_angle():
    chain = _chain(0.0)
    once, twice = _truth()
    vectors = SlowRollVectors(tuple(once), tuple(twice), (1e-8,) * 4, (2e-8,) * 4)
    omega, dt = 2 * math.pi * 75.0, 1e-3
    compensation = RunoutCompensation(vectors, omega, dt, first_sample_time_s=dt)
    true = np.array([3e-6, -20e-6, -1e-6, -25e-6])
    offsets = np.array([p.zero_offset_m for p in chain.probes])
    for step in (0, 7, 1234):
        theta = omega * (dt + step * dt)
        compensated = compensation.compensate(chain.probe_readings(true, theta), step)
        assert np.allclose(compensated, chain.projection @ true + offsets, atol=1e-15)
    assert np.allclose(np.diag(compensation.residual_covariance_m2()), 1e-16 + 4e-16)


def test_oilwatch_baseline_stores_the_slow_roll_vectors_and_names_a_bad_record(tmp_path, capsys):
    times, signals, theta = slow_roll_record(_chain(1.0), CLEARANCES_M, 75.0, 10.0, 1e-3, seed=5)
    path = tmp_path / "slow_roll.csv"
    table = np.column_stack([times, signals * 1e6, np.degrees(theta) % 360.0])
    np.savetxt(
        path, table, delimiter=",", header="time_s,x1_um,y1_um,x2_um,y2_um,rotor_angle_deg", comments=""
    )
    out = tmp_path / "baseline.json"
    assert main(["baseline", "--slow-roll-record", str(path), "--out", str(out)]) == 0
    vectors = load_runout(out)
    once, twice = _truth()
    assert np.allclose(vectors.once_m, once, atol=5 * max(vectors.once_std_m))
    assert np.allclose(vectors.twice_m, twice, atol=5 * max(vectors.twice_std_m))
    assert json.loads(out.read_text())["runout"]["runout_1x_std_um"][0] < 0.05
    # the same record by its speed (time 0 at the keyphasor) gives the same vectors
    speed = np.full(len(times), theta[0] / times[0] / (2 * math.pi))
    np.savetxt(
        path,
        np.column_stack([times, signals * 1e6, speed]),
        delimiter=",",
        comments="",
        header="time_s,x1_um,y1_um,x2_um,y2_um,speed_hz",
    )
    assert main(["baseline", "--slow-roll-record", str(path), "--out", str(out)]) == 0
    assert np.allclose(load_runout(out).once_m, vectors.once_m, atol=1e-12)
    np.savetxt(path, table[:, :5], delimiter=",", header="time_s,x1_um,y1_um,x2_um,y2_um", comments="")
    capsys.readouterr()
    assert main(["baseline", "--slow-roll-record", str(path), "--out", str(out)]) == 2
    assert "rotor_angle_deg or speed_hz" in capsys.readouterr().err


def test_too_short_a_slow_roll_record_is_refused():
    times = 1e-3 * np.arange(1, 200)
    with pytest.raises(InputError, match=r"probe x1 has 0\.7 revolution"):
        fit_slow_roll(times, np.zeros((len(times), 4)), 2 * math.pi * 3.75 * times)


def test_under_a_speed_ramp_the_compensation_angle_is_the_integral_of_the_measured_speed():
    """The estimator subtracts the runout at the operating model's rotor angle, the phase its unbalance
    forcing uses (the integral of the measured speed, or the keyphasor's), not nominal Omega t."""
    from oilwatch.models.machine import load_machine
    from oilwatch.models.system.factory import load_system
    from oilwatch.models.system.operating_model import build_operating_model

    machine = load_machine()
    model = build_operating_model(load_system(reduced=True), machine)
    dt = model.dt_s
    speeds = np.linspace(72.0, 78.0, 400)
    for step, speed in enumerate(speeds, start=1):
        model.set_operating_point(float(speed))
        angle = model.rotor_angle_rad(step)
        # the model's convention: a speed set at a step turns the rotor over the period after it
        expected = 2.0 * math.pi * dt * (speeds[0] + speeds[: step - 1].sum())
        w = model.exogenous(step)
        assert math.isclose(angle, expected, rel_tol=1e-12) and np.allclose(
            w[1:], [math.cos(angle), math.sin(angle)]
        )
    # a keyphasor angle given for the previous step re-anchors the rotor angle
    model.set_operating_point(75.0, rotor_angle_rad=1.0)
    assert math.isclose(model.rotor_angle_rad(len(speeds) + 1), 1.0 + 2.0 * math.pi * 75.0 * dt)
    vectors = SlowRollVectors((2e-6 + 1e-6j, 0j, 0j, 0j), (0j,) * 4, (0.0,) * 4, (0.0,) * 4)
    compensation = RunoutCompensation(vectors, 2.0 * math.pi * 75.0, dt, dt)
    assert np.allclose(compensation.compensate(np.zeros(4), 10, 0.3), -vectors.runout_m(0.3))
