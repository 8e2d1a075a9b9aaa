"""Cramer-Rao bound on (q1, q2): hand formulas, exact scaling, step insensitivity, and efficiency of a fit.

The rotor-bearing system here is the real finite-element rotor on a small stand-in coefficient table (smooth
functions of q around the short-bearing numbers of REFERENCE.md), so the tests do not depend on the bearing
solver's table.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import least_squares

from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.orbit_bound import (
    M3_S_TO_ML_MIN,
    OrbitSensitivity,
    cramer_rao_bound,
    fisher_information,
    orbit_sensitivity,
    record_sensitivity,
)
from oilwatch.models.system.rotor_bearing import RotorBearingSystem
from oilwatch.models.validation import InputError
from oilwatch.study.case_cosim import ModelCrlb
from oilwatch.study.grid import Case

Q_NOMINAL = 596.3 / M3_S_TO_ML_MIN
K_SHORT = np.array([[6.913e7, 3.105e8], [-3.251e8, 3.584e7]])
C_SHORT = np.array([[1.331e6, -1.468e5], [-1.468e5, 1.366e6]])


class StandInTable:
    """A coefficient table stand-in: coefficients and equilibrium vary smoothly (and nonlinearly) with q."""

    speed_hz = 75.0
    load_n = 3272.8
    mesh = (40, 10)
    flowrate_range_m3_s = (0.4 * Q_NOMINAL, 1.4 * Q_NOMINAL)

    def evaluate(self, q):
        starvation = 1.0 - q / Q_NOMINAL
        scale = 1.0 + 0.6 * starvation + 0.8 * starvation**2
        angle = np.deg2rad(70.0 - 25.0 * starvation)
        eccentricity = 12e-6 * (1.0 + 1.5 * starvation)
        return SimpleNamespace(
            eccentricity_m=eccentricity * np.array([np.sin(angle), -np.cos(angle)]),
            stiffness=K_SHORT * scale,
            damping=C_SHORT * (1.0 - 0.3 * starvation),
        )


@pytest.fixture(scope="module")
def system():
    rotor = Rotor.from_machine(load_machine())
    return RotorBearingSystem(rotor, [StandInTable(), StandInTable()], 75.0)


class LinearToy:
    """Toy orbit model, linear in q: x1 static = a q1, y2 orbit amplitude = b q2 (real), rest zero."""

    omega_rad_s = 2.0 * np.pi * 75.0
    bearing_flowrate_bounds_m3_s = np.array([(0.0, 1.0), (0.0, 1.0)])

    def __init__(self, a, b):
        self.a, self.b = a, b

    def static_coordinates(self, q):
        return np.array([self.a * q[0], 0.0, 0.0, 0.0])

    def unbalance_coordinates(self, q):
        return np.array([0.0, 0.0, 0.0, self.b * q[1]], dtype=complex)

    def bearing_positions(self, coordinates):
        return coordinates.reshape(2, 2)


def test_fisher_information_of_a_scalar_toy_matches_the_hand_formula():
    a, b, sigma, dt, n = 3.0, 5.0, 0.2, 1e-3, 1001
    toy = LinearToy(a, b)
    bound = cramer_rao_bound(toy, (0.3, 0.4), sigma, n, dt)
    t = dt * np.arange(n)
    expected = np.diag([n * a**2, b**2 * np.sum(np.cos(toy.omega_rad_s * t) ** 2)]) / sigma**2
    np.testing.assert_allclose(bound.fisher, expected, rtol=1e-9, atol=1e-9 * expected.max())
    np.testing.assert_allclose(bound.std_m3_s, 1.0 / np.sqrt(np.diag(expected)), rtol=1e-9)


def test_fisher_information_general_formula():
    rng = np.random.default_rng(3)
    jac = rng.normal(size=(50, 4, 2))
    manual = sum(j.T @ j for j in jac) / 0.5**2
    np.testing.assert_allclose(fisher_information(jac, 0.5), manual, rtol=1e-12)


def test_bound_scales_exactly_as_sigma_over_sqrt_n(system):
    q = (0.9 * Q_NOMINAL, 0.8 * Q_NOMINAL)
    # 40 samples at 1 kHz are exactly 3 revolutions at 75 Hz, so whole-revolution records scale exactly.
    reference = cramer_rao_bound(system, q, 1e-6, 400)
    for sigma_factor, n_factor in ((2.0, 1), (1.0, 4), (3.0, 25)):
        bound = cramer_rao_bound(system, q, sigma_factor * 1e-6, 400 * n_factor)
        np.testing.assert_allclose(
            bound.std_ml_min, reference.std_ml_min * sigma_factor / np.sqrt(n_factor), rtol=1e-9
        )


def test_sensitivity_is_step_insensitive(system):
    q = (0.85 * Q_NOMINAL, 0.95 * Q_NOMINAL)
    coarse = orbit_sensitivity(system, q, 1e-3)
    fine = orbit_sensitivity(system, q, 1e-5)
    np.testing.assert_allclose(coarse.static, fine.static, rtol=1e-4, atol=1e-6 * np.abs(fine.static).max())
    scale = np.abs(fine.amplitude).max()
    np.testing.assert_allclose(coarse.amplitude, fine.amplitude, rtol=1e-4, atol=1e-6 * scale)
    for step in (1e-3, 1e-5):
        bound = cramer_rao_bound(system, q, 1e-6, 2000, relative_step=step)
        reference = cramer_rao_bound(system, q, 1e-6, 2000)
        np.testing.assert_allclose(bound.std_ml_min, reference.std_ml_min, rtol=1e-4)


@pytest.mark.slow
def test_nonlinear_least_squares_fit_attains_the_bound(system):
    """A maximum-likelihood fit of (q1, q2) to noisy steady records is efficient: its std meets the bound."""
    q_true = np.array([0.9 * Q_NOMINAL, 0.8 * Q_NOMINAL])
    sigma, n, dt = 1e-6, 400, 1e-3
    bound = cramer_rao_bound(system, q_true, sigma, n, dt)
    phase = np.exp(1j * system.omega_rad_s * dt * np.arange(n))

    def record(q):
        static = system.bearing_positions(system.static_coordinates(q)).reshape(-1)
        amplitude = system.bearing_positions(system.unbalance_coordinates(q)).reshape(-1)
        return static[None, :] + (amplitude[None, :] * phase[:, None]).real

    clean = record(q_true)
    rng = np.random.default_rng(11)
    estimates = []
    for _ in range(150):
        noisy = clean + sigma * rng.normal(size=clean.shape)
        fit = least_squares(
            lambda x, data=noisy: ((record(x * Q_NOMINAL) - data) / sigma).ravel(),
            x0=[1.0, 1.0],
            x_scale=1e-3,
        )
        estimates.append(fit.x * Q_NOMINAL)
    errors = np.array(estimates) - q_true
    achieved = np.sqrt(np.mean(errors**2, axis=0))
    # 150 draws: the sample RMS has a relative std of about 1/sqrt(300) = 6 %.
    np.testing.assert_allclose(achieved / bound.std_m3_s, 1.0, atol=0.2)
    assert np.all(np.abs(errors.mean(axis=0)) < 3.0 * bound.std_m3_s / np.sqrt(len(errors)))


def test_bound_in_percent_and_ml_min_agree(system):
    q = (0.75 * Q_NOMINAL, Q_NOMINAL)
    bound = cramer_rao_bound(system, q, 2e-6, 10_000)
    np.testing.assert_allclose(bound.std_pct, 100.0 * bound.std_ml_min / (np.array(q) * M3_S_TO_ML_MIN))
    assert np.all(bound.std_pct > 0.0) and abs(bound.correlation) < 1.0


def test_bad_input_names_the_argument(system):
    q = (Q_NOMINAL, Q_NOMINAL)
    with pytest.raises(InputError, match="noise_std_m"):
        cramer_rao_bound(system, q, -1e-6, 100)
    with pytest.raises(InputError, match="n_samples"):
        cramer_rao_bound(system, q, 1e-6, 0)
    with pytest.raises(InputError, match="q1"):
        cramer_rao_bound(system, (2.0 * Q_NOMINAL, Q_NOMINAL), 1e-6, 100)
    with pytest.raises(InputError, match="not locally identifiable"):
        cramer_rao_bound(LinearToy(0.0, 1.0), (0.3, 0.4), 1e-6, 100)


def test_study_case_bound_uses_the_whole_record_and_the_case_noise(system):
    case = Case(90.0, 80.0, 2.0, duration_s=2.0, discard_s=1.0)
    bound = ModelCrlb(system=system)(case)
    direct = cramer_rao_bound(system, (0.9 * Q_NOMINAL, 0.8 * Q_NOMINAL), 2e-6, 2000)
    np.testing.assert_allclose(bound, direct.std_ml_min, rtol=1e-7)


def test_unknown_sensor_offsets_leave_only_the_orbit_information(system):
    q = (0.9 * Q_NOMINAL, 0.8 * Q_NOMINAL)
    n, sigma = 400, 1e-6  # whole revolutions: the harmonic part has zero mean, so offsets decouple from it
    sensitivity = orbit_sensitivity(system, q)
    orbit_only = OrbitSensitivity(np.zeros_like(sensitivity.static), sensitivity.amplitude)
    expected = fisher_information(record_sensitivity(orbit_only, system.omega_rad_s, 1e-3, n), sigma)
    bound = cramer_rao_bound(system, q, sigma, n, unknown_offsets=True)
    np.testing.assert_allclose(bound.fisher, expected, rtol=1e-6)
    assert np.all(bound.std_m3_s > cramer_rao_bound(system, q, sigma, n).std_m3_s)


def test_bound_with_the_real_coefficient_table():
    """The committed table: the reduced model (used by the EKF) carries the full model's information."""
    full, reduced = load_system(reduced=False), load_system(reduced=True)
    for pct in ((100.0, 100.0), (98.0, 85.0), (75.0, 75.0)):
        q = np.array(pct) / 100.0 * Q_NOMINAL
        bound = cramer_rao_bound(full, q, 1e-6, 10_000)
        assert np.all(np.isfinite(bound.std_pct)) and np.all(bound.std_pct > 0.0)
        reduced_bound = cramer_rao_bound(reduced, q, 1e-6, 10_000)
        np.testing.assert_allclose(reduced_bound.std_pct, bound.std_pct, rtol=1e-3)
        coarse = cramer_rao_bound(full, q, 1e-6, 10_000, relative_step=1e-3)
        np.testing.assert_allclose(coarse.std_pct, bound.std_pct, rtol=1e-4)
        assert np.all(cramer_rao_bound(full, q, 1e-6, 10_000, unknown_offsets=True).std_pct > bound.std_pct)
