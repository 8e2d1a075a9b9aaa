"""The toy rotor used to test the estimator: its Jacobians, its discrete map against RK4, its physics."""

from __future__ import annotations

import numpy as np
import pytest
from fixtures.toy_model import NOMINAL_FLOWRATE_M3_S, TABLE_BOUNDS_M3_S, ToyRotor, simulate

from oilwatch.estimator.ekf_config import ML_MIN


@pytest.fixture(scope="module")
def toy():
    return ToyRotor()


def test_stable_over_the_whole_table(toy):
    for q1 in np.linspace(*TABLE_BOUNDS_M3_S, 5):
        for q2 in np.linspace(*TABLE_BOUNDS_M3_S, 5):
            assert toy.continuous_eigenvalues(np.array([q1, q2])).real.max() < 0.0


def test_first_mode_near_the_turbines(toy):
    frequencies = np.abs(toy.continuous_eigenvalues(np.full(2, NOMINAL_FLOWRATE_M3_S)).imag)
    assert 50.0 < frequencies.min() / (2 * np.pi) < 60.0


def test_jacobians_match_central_differences(toy):
    rng = np.random.default_rng(0)
    state = 1e-5 * rng.standard_normal(8)
    q = np.array([500.0, 610.0]) * ML_MIN
    _, state_jac, flow_jac = toy.transition(state, q, 17)
    h_state = 1e-9
    for j in range(8):
        e = np.zeros(8)
        e[j] = h_state
        column = (toy.transition(state + e, q, 17)[0] - toy.transition(state - e, q, 17)[0]) / 2e-9
        np.testing.assert_allclose(column, state_jac[:, j], rtol=1e-6, atol=1e-10)
    h_flow = 1e-3 * ML_MIN  # inside one grid cell, where the interpolant is smooth
    for j in range(2):
        e = np.zeros(2)
        e[j] = h_flow
        column = (toy.transition(state, q + e, 17)[0] - toy.transition(state, q - e, 17)[0]) / (2 * h_flow)
        np.testing.assert_allclose(column, flow_jac[:, j], rtol=1e-5, atol=1e-12)


def test_discrete_map_follows_the_rk4_truth(toy):
    """One step of the interpolated exact map from the true state lands on the RK4 truth within 1 nm."""
    q = np.array([0.8, 0.9]) * NOMINAL_FLOWRATE_M3_S
    record = simulate(toy, np.tile(q, (400, 1)), 0.0)
    for k in (100, 250, 398):
        predicted = toy.transition(record.states[k], q, k)[0]
        assert np.abs(predicted[:4] - record.states[k + 1, :4]).max() < 1e-9


def test_static_position_and_orbit_are_turbine_sized(toy):
    nominal = toy.static_state(np.full(2, NOMINAL_FLOWRATE_M3_S))
    starved = toy.static_state(np.full(2, 0.75 * NOMINAL_FLOWRATE_M3_S))
    shift = np.hypot(*(starved[:2] - nominal[:2]))
    assert 3e-6 < shift < 10e-6
    record = simulate(toy, np.full((2000, 2), NOMINAL_FLOWRATE_M3_S), 0.0)
    amplitude = np.ptp(record.displacement_true_m[1000:], axis=0) / 2
    assert (amplitude > 1e-6).all() and (amplitude < 50e-6).all()
