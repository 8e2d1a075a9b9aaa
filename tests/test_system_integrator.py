"""The plant's Newmark integrator and the sigmoid fault schedule (physics behind the plant FMU)."""

import numpy as np
import pytest

from oilwatch.models.system.factory import load_system
from oilwatch.models.system.fault import SigmoidFlowrate
from oilwatch.models.system.newmark import NewmarkIntegrator
from oilwatch.models.validation import InputError

ML = 1e-6 / 60.0
NOMINAL = 596.3 * ML


def constant(q):
    """A schedule holding the flowrates ``q`` (q1, q2)."""
    return lambda times: np.tile(np.asarray(q, dtype=float), (len(times), 1))


@pytest.fixture(scope="module")
def full():
    return load_system(reduced=False)


def _orbit_error(system, substeps, q, n_steps=1500):
    integrator = NewmarkIntegrator(system, 1e-3, substeps, (NOMINAL, NOMINAL))
    integrator.reset(0.0, q, "static")
    outputs = np.array(
        [system.bearing_positions(integrator.advance(constant(q))).ravel() for _ in range(n_steps)]
    )
    times = np.arange(1, n_steps + 1) * 1e-3
    static = system.bearing_positions(system.static_coordinates(q)).ravel()
    amplitude = system.bearing_positions(system.unbalance_coordinates(q)).ravel()
    expected = static + (amplitude[None, :] * np.exp(1j * system.omega_rad_s * times)[:, None]).real
    return np.abs(outputs - expected)[-200:].max() / np.abs(amplitude).max()


def test_newmark_settles_on_the_harmonic_response_with_second_order_accuracy(full):
    q = (0.9 * NOMINAL, 0.8 * NOMINAL)
    coarse, fine = _orbit_error(full, 4, q), _orbit_error(full, 8, q)
    assert fine < 0.005
    assert 3.0 < coarse / fine < 5.0  # trapezoidal rule: halving the step divides the error by 4


def test_time_varying_path_equals_the_cached_propagator(full):
    q = (NOMINAL, 0.9 * NOMINAL)
    cached = NewmarkIntegrator(full, 1e-3, 8, (NOMINAL, NOMINAL))
    stepped = NewmarkIntegrator(full, 1e-3, 8, (NOMINAL, NOMINAL))
    cached.reset(0.0, q)
    stepped.reset(0.0, q)
    for k in range(50):
        cached.advance(constant(q))
        # A flow change just above the constant-flow tolerance (physically negligible) forces sub-steps.
        stepped.advance(
            lambda t, k=k: np.column_stack([q[0] * (1 + 3e-9 * (t - k * 1e-3) / 1e-3), np.full(len(t), q[1])])
        )
    # Displacements and velocities (the cached path leaves the acceleration stale until it is needed);
    # tolerances of 1e-6 of the orbit and of its velocity.
    n = full.n_coordinates
    assert np.abs(cached.state[:n] - stepped.state[:n]).max() < 2.5e-12
    assert np.abs(cached.state[n : 2 * n] - stepped.state[n : 2 * n]).max() < 1.2e-9


def test_flow_step_moves_the_static_position_by_the_table_prediction(full):
    start, end = (NOMINAL, NOMINAL), (0.8 * NOMINAL, NOMINAL)
    integrator = NewmarkIntegrator(full, 1e-3, 8, start)
    integrator.reset(0.0, start, "static")
    schedule = SigmoidFlowrate(start[0], end[0], 0.2, 0.05)
    period = round(1.0 / full.speed_hz / 1e-3 * 3)  # 40 samples = 3 revolutions at 75 Hz
    history = [
        full.bearing_positions(
            integrator.advance(lambda t: np.column_stack([schedule(t), np.full(len(t), NOMINAL)]))
        )
        for _ in range(2000)
    ]
    mean_after = np.mean(history[-period:], axis=0)
    expected = full.bearing_positions(full.static_coordinates(end))
    assert np.abs(mean_after - expected).max() < 0.02e-6


def test_sigmoid_follows_its_formula_and_rise_time():
    s = SigmoidFlowrate(596.3, 447.2, 10.0, 1.0)
    t = np.linspace(0, 20, 2001)
    tau = 1.0 / (2 * np.log(9))
    assert np.allclose(s(t), 596.3 + (447.2 - 596.3) / (1 + np.exp(-(t - 10.0) / tau)), rtol=1e-13)
    assert s(9.5) == pytest.approx(596.3 - 0.1 * 149.1)
    assert s(10.5) == pytest.approx(596.3 - 0.9 * 149.1)
    with pytest.raises(InputError, match="fault_duration_s"):
        SigmoidFlowrate(1.0, 0.5, 10.0, 0.0)
