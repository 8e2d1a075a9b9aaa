"""Uniform shafts against analytical beam theory: natural frequencies, gyroscopic splitting, sag.

References: Timoshenko beam frequency equation of a simply supported beam (e.g. Friswell et al.
2010, sec. 5.4; Han, Benaroya & Wei, J. Sound Vib. 225, 1999); Euler-Bernoulli free-free beam
(beta L = 4.7300, 7.8532, 10.9956, 14.1372); spinning shaft: the rotary inertia rho I omega^2 becomes
rho I omega (omega -+ 2 Omega) for forward/backward circular whirl.
"""

from __future__ import annotations

import numpy as np
import pytest

from oilwatch.models.machine import load_machine
from oilwatch.models.machine_sections import Material
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.rotor.modal import damped_modes, undamped_natural_frequencies_hz
from oilwatch.models.rotor.response import static_deflection
from oilwatch.models.rotor.supports import isotropic_bearings
from oilwatch.models.rotor.timoshenko import cowper_shear_coefficient

STEEL = Material(210e9, 0.3, 7850.0)


def uniform_rotor(n_elements: int, length: float, diameter: float) -> Rotor:
    return Rotor.build(np.full(n_elements, length / n_elements), np.full(n_elements, diameter), STEEL)


def simply_supported_frequencies_hz(rotor: Rotor, n_modes: int) -> np.ndarray:
    """Lowest distinct frequencies with V = W = 0 at both ends (dofs eliminated)."""
    import scipy.linalg

    last = rotor.n_nodes
    fixed = [rotor.dof(n, d) for n in (1, last) for d in ("x", "y")]
    free = np.setdiff1d(np.arange(rotor.n_dof), fixed)
    eig = scipy.linalg.eigh(
        rotor.stiffness_matrix[np.ix_(free, free)],
        rotor.mass_matrix[np.ix_(free, free)],
        eigvals_only=True,
    )
    # Each frequency appears twice (x and y bending planes).
    return np.sqrt(eig[: 2 * n_modes : 2]) / (2 * np.pi)


def timoshenko_ss_hz(n: int, length: float, diameter: float, spin_hz: float = 0.0, whirl=0):
    """Simply supported (spinning) Timoshenko shaft, mode n; whirl +1 forward, -1 backward."""
    area, inertia = np.pi * diameter**2 / 4, np.pi * diameter**4 / 64
    rho, e_mod = STEEL.density_kg_m3, STEEL.youngs_modulus_pa
    kga = cowper_shear_coefficient(STEEL.poisson_ratio) * STEEL.shear_modulus_pa * area
    k = n * np.pi / length
    a, b, c = rho * area, kga * k**2, rho * inertia
    s = -2.0 * whirl * 2 * np.pi * spin_hz
    d, e = e_mod * inertia * k**2 + kga, (kga * k) ** 2
    # (a w^2 - b)(c w^2 + c s w - d) - e = 0
    roots = np.roots([a * c, a * c * s, -a * d - b * c, -b * c * s, b * d - e])
    real = roots[(np.abs(roots.imag) < 1e-6 * np.abs(roots)) & (roots.real > 0)].real
    return real.min() / (2 * np.pi)


def test_simply_supported_timoshenko_converges():
    length, diameter = 1.0, 0.1  # L/D = 10: shear and rotary inertia matter
    exact = np.array([timoshenko_ss_hz(n, length, diameter) for n in range(1, 5)])
    errors = []
    for n_el in (6, 12, 24):
        fe = simply_supported_frequencies_hz(uniform_rotor(n_el, length, diameter), 4)
        errors.append(np.abs(fe / exact - 1))
    assert np.all(errors[-1] < 0.005), errors[-1]
    # Monotone convergence, at least second order.
    assert np.all(errors[1] < errors[0] / 3.5) and np.all(errors[2] < errors[1] / 3.5)
    # The test discriminates: Euler-Bernoulli is 9 % off on the 4th mode of this stubby beam.
    area, inertia = np.pi * diameter**2 / 4, np.pi * diameter**4 / 64
    eb4 = (4 * np.pi / length) ** 2 * np.sqrt(210e9 * inertia / (7850 * area)) / (2 * np.pi)
    assert eb4 / exact[3] - 1 > 0.08


def test_free_free_slender_shaft_matches_euler_bernoulli():
    length, diameter = 2.0, 0.01  # L/D = 200
    rotor = uniform_rotor(20, length, diameter)
    freqs = undamped_natural_frequencies_hz(rotor)
    # Four rigid-body modes (two translations, two tilts) at zero.
    assert np.all(freqs[:4] < 1e-4 * freqs[4])
    area, inertia = np.pi * diameter**2 / 4, np.pi * diameter**4 / 64
    beta_l = np.array([4.730041, 7.853205, 10.995608, 14.137165])
    exact = beta_l**2 * np.sqrt(210e9 * inertia / (7850 * area * length**4)) / (2 * np.pi)
    fe = freqs[4::2][:4]
    np.testing.assert_allclose(freqs[5::2][:4], fe, rtol=1e-9)
    np.testing.assert_allclose(fe, exact, rtol=0.005)


def test_turbine_free_free_rigid_body_modes():
    freqs = undamped_natural_frequencies_hz(Rotor.from_machine(load_machine()))
    assert np.all(freqs[:4] < 1e-4 * freqs[4])
    assert freqs[4] > 50.0


def test_spinning_shaft_gyroscopic_splitting():
    length, diameter, spin_hz = 1.0, 0.2, 1000.0  # stubby, fast: strong gyroscopic effect
    rotor = uniform_rotor(24, length, diameter)
    stiff = isotropic_bearings([1, rotor.n_nodes], 1e13, 0.0)
    modes = damped_modes(rotor, spin_hz, stiff, n_modes=4)
    backward = [m.frequency_hz for m in modes if m.whirl == "backward"]
    forward = [m.frequency_hz for m in modes if m.whirl == "forward"]
    assert len(backward) == len(forward) == 2
    for n in (1, 2):
        assert forward[n - 1] == pytest.approx(timoshenko_ss_hz(n, length, diameter, spin_hz, +1), rel=0.005)
        assert backward[n - 1] == pytest.approx(timoshenko_ss_hz(n, length, diameter, spin_hz, -1), rel=0.005)
    # The split is 8-11 %, far more than the tolerance: the test sees the gyroscopic matrix.
    assert forward[1] - backward[1] > 0.05 * forward[1]
    # Undamped, conservative system: eigenvalues on the imaginary axis.
    assert all(abs(m.log_decrement) < 1e-6 for m in modes)


def test_simply_supported_sag_under_own_weight():
    length, diameter = 1.0, 0.1
    rotor = uniform_rotor(10, length, diameter)
    sag = static_deflection(rotor, isotropic_bearings([1, 11], 1e9, 0.0))
    y = sag[1::4]
    midspan = y[5] - 0.5 * (y[0] + y[10])  # the springs only add a rigid-body drop
    area, inertia = np.pi * diameter**2 / 4, np.pi * diameter**4 / 64
    w = 7850 * area * 9.81
    kga = cowper_shear_coefficient(0.3) * STEEL.shear_modulus_pa * area
    bending = 5 * w * length**4 / (384 * 210e9 * inertia)
    shear = w * length**2 / (8 * kga)
    assert midspan == pytest.approx(-(bending + shear), rel=1e-9)
    assert shear > 0.01 * bending  # shear deformation is resolved, not negligible here
    # Slopes at the supports: B = -dW/dz, so the left end (W falling) has B > 0.
    assert sag[2] > 0 and sag[rotor.dof(11, "rx")] == pytest.approx(-sag[2], rel=1e-9)
