"""The compiled EKF kernels against the textbook formulas (Eqs. 20, 22-24) evaluated with numpy."""

from __future__ import annotations

import numpy as np
import pytest

from oilwatch.estimator.kernels import (
    UPDATE_ACCEPTED,
    UPDATE_GATED,
    UPDATE_NOT_POSITIVE,
    predict_covariance,
    project_flowrates,
    update,
)


def _random_problem(n=12, m=4, seed=0):
    rng = np.random.default_rng(seed)
    size = n + 2
    factor = rng.standard_normal((size, size))
    covariance = factor @ factor.T + size * np.eye(size)
    observation = np.zeros((m, size))
    observation[:, :n] = rng.standard_normal((m, n))
    noise = np.diag(rng.uniform(0.5, 2.0, m))
    return rng, covariance, observation, noise


def test_predict_matches_j_p_jt_plus_q():
    rng, covariance, _, _ = _random_problem()
    n = covariance.shape[0] - 2
    state_jac = 0.3 * rng.standard_normal((n, n))
    flow_jac = rng.standard_normal((n, 2))
    process = np.diag(rng.uniform(0.1, 1.0, n + 2))
    jacobian = np.eye(n + 2)
    jacobian[:n, :n] = state_jac
    jacobian[:n, n:] = flow_jac
    expected = jacobian @ covariance @ jacobian.T + process
    scratch = np.zeros_like(covariance), np.zeros_like(covariance)
    scale = np.array([3.0, 5.0])  # each bearing's flowrate unit
    predict_covariance(covariance, state_jac, flow_jac / scale, scale, np.zeros((n, 0)), process, *scratch)
    np.testing.assert_allclose(covariance, expected, rtol=1e-12, atol=1e-12 * abs(expected).max())
    assert np.array_equal(covariance, covariance.T)


@pytest.mark.parametrize("m", [4, 8])
def test_update_matches_the_kalman_equations(m):
    rng, covariance, observation, noise = _random_problem(m=m)
    state = rng.standard_normal(covariance.shape[0])
    measured = rng.standard_normal(m)
    innovation_cov = observation @ covariance @ observation.T + noise
    gain = covariance @ observation.T @ np.linalg.inv(innovation_cov)
    innovation = measured - observation @ state
    expected_state = state + gain @ innovation
    expected_cov = (np.eye(len(state)) - gain @ observation) @ covariance
    expected_nis = innovation @ np.linalg.solve(innovation_cov, innovation)

    status, nis = update(state, covariance, observation, measured, noise, np.inf)
    assert status == UPDATE_ACCEPTED
    assert nis == pytest.approx(expected_nis, rel=1e-10)
    np.testing.assert_allclose(state, expected_state, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(covariance, expected_cov, rtol=1e-9, atol=1e-10)
    assert np.array_equal(covariance, covariance.T)
    np.linalg.cholesky(covariance)


def test_repeated_updates_keep_p_positive_definite_across_eight_decades():
    """A prior 1e8 times the measurement noise (the start-up situation: (100 um)^2 against (1 um)^2 and
    beyond), updated 200 times with small process noise in between, stays SPD and exactly symmetric."""
    rng, covariance, observation, _ = _random_problem(n=20, m=4, seed=3)
    covariance *= 1e8
    state = np.zeros(covariance.shape[0])
    for _ in range(200):
        status, _ = update(state, covariance, observation, rng.standard_normal(4), np.eye(4), np.inf)
        assert status == UPDATE_ACCEPTED
        covariance += 1e-6 * np.eye(covariance.shape[0])
        assert np.array_equal(covariance, covariance.T)
        scale = 1.0 / np.sqrt(np.diag(covariance))
        np.linalg.cholesky(covariance * np.outer(scale, scale))


def test_gate_leaves_state_and_covariance_untouched():
    rng, covariance, observation, noise = _random_problem()
    state = rng.standard_normal(covariance.shape[0])
    before = state.copy(), covariance.copy()
    measured = observation @ state + 1e6
    status, nis = update(state, covariance, observation, measured, noise, 30.0)
    assert status == UPDATE_GATED
    assert nis > 30.0
    assert np.array_equal(state, before[0])
    assert np.array_equal(covariance, before[1])


def test_indefinite_innovation_covariance_is_reported_not_used():
    _, covariance, observation, _ = _random_problem()
    state = np.zeros(covariance.shape[0])
    before = covariance.copy()
    status, _ = update(state, covariance, observation, np.zeros(4), -1e9 * np.eye(4), np.inf)
    assert status == UPDATE_NOT_POSITIVE
    assert np.array_equal(covariance, before)


@pytest.mark.parametrize("flowrates", [(0.3, 1.0), (1.0, 1.6), (0.2, 1.7), (1.0, 0.5), (1.0, 1.3)])
def test_projection_is_the_p_metric_projection_onto_each_bearings_bounds(flowrates):
    """Bearing 2's range (0.6, 1.2) lies inside bearing 1's (0.45, 1.4): its 0.5 and 1.3 are past its own."""
    _, covariance, _, _ = _random_problem()
    size = covariance.shape[0]
    state = np.linspace(-1.0, 1.0, size)
    state[-2:] = flowrates
    low, high = np.array([0.45, 0.6]), np.array([1.4, 1.2])
    active = [b for b in range(2) if not low[b] <= flowrates[b] <= high[b]]
    rows = [size - 2 + b for b in active]
    target = np.clip(state[rows], low[active], high[active])
    expected = state - covariance[:, rows] @ np.linalg.solve(
        covariance[np.ix_(rows, rows)], state[rows] - target
    )
    project_flowrates(state, covariance, np.column_stack([low, high]).ravel())
    np.testing.assert_allclose(state, expected, rtol=1e-12, atol=1e-12)
    assert np.all((low <= state[-2:]) & (state[-2:] <= high))
