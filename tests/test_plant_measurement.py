"""The plant's measurement chain: each parameter changes the measured signals as documented, and only them."""

import math

import numpy as np
import pytest

from oilwatch.models.system.factory import load_system
from oilwatch.models.system.measurement import MeasurementChain, ProbeErrors, UnbalanceChange
from oilwatch.models.system.plant import RotorBearingPlant
from oilwatch.models.validation import InputError

ML = 1e-6 / 60.0
NOMINAL = 596.3 * ML
STEPS = 40


@pytest.fixture(scope="module")
def system():
    return load_system(reduced=False)


def _run(system, chain=None, steps=STEPS, noise=1e-6, **kwargs):
    plant = RotorBearingPlant(
        system, 1e-3, None, noise, seed=3, initial_flowrates_m3_s=(NOMINAL, NOMINAL), chain=chain, **kwargs
    )
    samples = [plant.step((NOMINAL, NOMINAL)) for _ in range(steps)]
    times = np.arange(1, steps + 1) * 1e-3
    return (
        times,
        np.array([s.true_position_m for s in samples]),
        np.array([s.measured_position_m for s in samples]),
        samples,
        plant,
    )


@pytest.fixture(scope="module")
def reference(system):
    return _run(system)


def _chain(probe=0, **errors):
    probes = [ProbeErrors()] * 4
    probes[probe] = ProbeErrors(**errors)
    return MeasurementChain(tuple(probes))


def test_ideal_chain_is_the_true_position_plus_seeded_noise(reference):
    _, true, measured, _, _ = reference
    noise = 1e-6 * np.random.default_rng(3).standard_normal((STEPS, 4))
    np.testing.assert_allclose(measured - true, noise, atol=1e-18)


def test_zero_offset_adds_to_its_probe_only(system, reference):
    _, true, measured, _, _ = _run(system, _chain(1, zero_offset_m=5e-6))
    np.testing.assert_allclose(true, reference[1], atol=0)
    delta = measured - reference[2]
    np.testing.assert_allclose(delta[:, 1], 5e-6, rtol=1e-9)
    np.testing.assert_allclose(delta[:, [0, 2, 3]], 0.0, atol=1e-18)


def test_sensitivity_error_scales_the_reading(system, reference):
    _, true, measured, _, _ = _run(system, _chain(2, sensitivity_error=0.05))
    delta = measured - reference[2]
    np.testing.assert_allclose(delta[:, 2], 0.05 * true[:, 2], rtol=1e-9)
    np.testing.assert_allclose(delta[:, [0, 1, 3]], 0.0, atol=1e-18)


def test_api670_mounting_reads_the_projections_at_45_degrees(system, reference):
    _, true, measured, _, _ = _run(system, MeasurementChain(mounting_angle_rad=math.pi / 4))
    noise = reference[2] - reference[1]
    s = math.sqrt(0.5)
    expected = np.column_stack(
        [
            s * (true[:, 0] + true[:, 1]),
            s * (-true[:, 0] + true[:, 1]),
            s * (true[:, 2] + true[:, 3]),
            s * (-true[:, 2] + true[:, 3]),
        ]
    )
    np.testing.assert_allclose(measured, expected + noise, atol=1e-15)


@pytest.mark.parametrize("order", [1, 2])
def test_runout_is_a_harmonic_of_the_rotor_angle(system, reference, order):
    errors = {f"runout_{order}x_m": 2e-6, f"runout_{order}x_phase_rad": 0.7}
    times, _, measured, _, _ = _run(system, _chain(3, **errors))
    omega = system.omega_rad_s
    np.testing.assert_allclose(
        measured[:, 3] - reference[2][:, 3], 2e-6 * np.cos(order * omega * times + 0.7), atol=1e-15
    )


def test_dead_probe_reads_nan_from_its_fault_time(system, reference):
    times, _, measured, _, _ = _run(system, _chain(0, fault="dead", fault_time_s=0.0205))
    assert np.all(np.isnan(measured[times >= 0.0205, 0]))
    np.testing.assert_allclose(measured[times < 0.0205], reference[2][times < 0.0205], atol=0)
    assert np.isfinite(measured[:, 1:]).all()


def test_stuck_probe_repeats_its_last_value(system, reference):
    times, _, measured, _, _ = _run(system, _chain(1, fault="stuck", fault_time_s=0.0205))
    last = reference[2][times < 0.0205, 1][-1]
    np.testing.assert_allclose(measured[times >= 0.0205, 1], last, atol=0)
    np.testing.assert_allclose(measured[times < 0.0205, 1], reference[2][times < 0.0205, 1], atol=0)


def test_glitch_adds_its_size_for_its_length(system, reference):
    chain = _chain(2, fault="glitch", fault_time_s=0.0105, glitch_m=30e-6, glitch_duration_s=0.005)
    times, _, measured, _, _ = _run(system, chain)
    inside = (times >= 0.0105) & (times < 0.0155)
    delta = measured[:, 2] - reference[2][:, 2]
    np.testing.assert_allclose(delta[inside], 30e-6, rtol=1e-9)
    np.testing.assert_allclose(delta[~inside], 0.0, atol=1e-18)
    assert inside.sum() == 5


def test_unbalance_change_moves_the_orbit_to_the_new_unbalance(system):
    moment = system.unbalance_moment_kg_m
    change = UnbalanceChange(
        time_s=0.05, moment_kg_m=2.0 * moment, phase_rad=system.unbalance_phase_rad + math.pi
    )
    times, true, _, _, _ = _run(system, steps=1500, noise=0.0, unbalance_change=change)
    static = system.bearing_positions(system.static_coordinates((NOMINAL, NOMINAL))).ravel()
    amplitude = system.bearing_positions(system.unbalance_coordinates((NOMINAL, NOMINAL))).ravel()
    rotating = np.exp(1j * system.omega_rad_s * times)[:, None]
    before = static + (amplitude * rotating).real
    after = static + (-2.0 * amplitude * rotating).real
    scale = np.abs(amplitude).max()
    assert np.abs(true[times < 0.05] - before[times < 0.05]).max() < 0.01 * scale
    assert np.abs(true[-200:] - after[-200:]).max() < 0.03 * scale


def test_film_outputs_follow_the_true_position(system, reference):
    _, true, _, samples, plant = reference
    c = plant._clearance_m[0]
    for row, sample in zip(true, samples, strict=True):
        ratio = np.hypot(row[[0, 2]], row[[1, 3]]) / c
        np.testing.assert_allclose(sample.eccentricity_ratio, ratio, rtol=1e-12)
        np.testing.assert_allclose(sample.min_film_thickness_m, c * (1 - ratio), rtol=1e-12)
    assert 0.05 < samples[-1].eccentricity_ratio[0] < 0.3


def test_bad_chain_parameters_are_refused_naming_them():
    with pytest.raises(InputError, match="sensitivity_error"):
        ProbeErrors(sensitivity_error=2.0)
    with pytest.raises(InputError, match="probe fault"):
        ProbeErrors(fault="broken")
    with pytest.raises(InputError, match="mounting angle"):
        MeasurementChain(mounting_angle_rad=4.0)


def test_a_zero_offset_drifts_at_its_rate():
    chain = MeasurementChain((ProbeErrors(zero_offset_m=2e-6, zero_drift_m_s=5e-8),) + (ProbeErrors(),) * 3)
    held = np.zeros(4)
    rng = np.random.default_rng(0)
    start, later = (chain.measure(np.zeros(4), 0.0, t, rng, held) for t in (0.0, 60.0))
    assert start[0] == pytest.approx(2e-6) and later[0] == pytest.approx(5e-6) and later[1] == 0.0
