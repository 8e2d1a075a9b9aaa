"""Timoshenko element and rigid disc: symmetry, definiteness, skew gyroscopics, limiting cases."""

from __future__ import annotations

import numpy as np
import pytest

from oilwatch.models.machine import load_machine
from oilwatch.models.machine_sections import Material
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.rotor.disc import RigidDisc
from oilwatch.models.rotor.supports import LinearBearing, bearing_matrices
from oilwatch.models.rotor.timoshenko import (
    cowper_shear_coefficient,
    element_gyroscopic,
    element_mass,
    element_stiffness,
    shear_parameter,
)

STEEL = Material(210e9, 0.3, 7850.0)


@pytest.fixture(scope="module")
def turbine_elements():
    machine = load_machine()
    args = (machine.element_lengths_m, machine.element_diameters_m, STEEL)
    return element_mass(*args), element_stiffness(*args), element_gyroscopic(*args)


def test_cowper_coefficient():
    # Cowper (1966), solid circle: 6 (1 + nu) / (7 + 6 nu); nu = 0.3 gives 0.8864.
    assert cowper_shear_coefficient(0.3) == pytest.approx(7.8 / 8.8)
    assert cowper_shear_coefficient(0.0) == pytest.approx(6.0 / 7.0)


def test_element_matrices_symmetry_and_definiteness(turbine_elements):
    mass, stiffness, gyro = turbine_elements
    assert mass.shape == stiffness.shape == gyro.shape == (20, 8, 8)
    np.testing.assert_allclose(mass, mass.transpose(0, 2, 1), rtol=0, atol=1e-12 * np.abs(mass).max())
    np.testing.assert_allclose(stiffness, stiffness.transpose(0, 2, 1), rtol=1e-13)
    np.testing.assert_allclose(gyro, -gyro.transpose(0, 2, 1), rtol=1e-13)
    for m, k in zip(mass, stiffness, strict=True):
        assert np.linalg.eigvalsh(m).min() > 0.0
        eig_k = np.linalg.eigvalsh(k)
        # A free beam element has 4 rigid-body motions: 2 translations, 2 rotations.
        assert np.all(eig_k[:4] < 1e-9 * eig_k[-1])
        assert np.all(eig_k[4:] > 1e-6 * eig_k[-1])


def test_stiffness_annihilates_rigid_body_motion(turbine_elements):
    _, stiffness, _ = turbine_elements
    machine = load_machine()
    for k, length in zip(stiffness, machine.element_lengths_m, strict=True):
        # Rigid tilt of the axis towards +x: Gamma = a, V = a z; towards -y: B = a, W = -a z.
        tilt_x = np.array([0, 0, 0, 1.0, length, 0, 0, 1.0])
        tilt_y = np.array([0, 0, 1.0, 0, 0, -length, 1.0, 0])
        for motion in (tilt_x, tilt_y):
            assert np.abs(k @ motion).max() < 1e-9 * np.abs(k).max()
        # The same tilt with the wrong sign bends the element.
        wrong = np.array([0, 0, 1.0, 0, 0, length, 1.0, 0])
        assert np.abs(k @ wrong).max() > 1e-3 * np.abs(k).max()


def test_element_mass_reproduces_rigid_translation_mass():
    lengths, diameters = np.array([0.3, 0.05]), np.array([0.1, 0.2])
    mass = element_mass(lengths, diameters, STEEL)
    translation = np.array([1.0, 0, 0, 0, 1.0, 0, 0, 0])
    expected = STEEL.density_kg_m3 * np.pi * diameters**2 / 4 * lengths
    np.testing.assert_allclose(np.einsum("i,nij,j->n", translation, mass, translation), expected)


def test_shear_vanishes_for_slender_elements():
    phi = shear_parameter(np.array([10.0]), np.array([0.01]), STEEL)
    assert phi[0] < 1e-5
    assert shear_parameter(np.array([0.045]), np.array([0.2625]), STEEL)[0] > 1.0


def test_annular_disc_inertia():
    disc = RigidDisc.annulus(7850.0, 0.05, 0.6, 0.1875)
    assert disc.mass_kg == pytest.approx(100.14, abs=0.01)
    # Thin solid disc limits: Ip = m R^2 / 2, Id = Ip / 2.
    thin = RigidDisc.annulus(1000.0, 1e-6, 1.0, 0.0)
    assert thin.polar_inertia_kg_m2 == pytest.approx(thin.mass_kg * 0.25 / 2)
    assert thin.diametral_inertia_kg_m2 == pytest.approx(thin.polar_inertia_kg_m2 / 2)
    # A long thin-walled tube: Id = m R^2 / 2 + m h^2 / 12 -> dominated by the length term.
    tube = RigidDisc.annulus(1000.0, 2.0, 0.1, 0.0999)
    assert tube.diametral_inertia_kg_m2 == pytest.approx(tube.mass_kg * (0.05**2 / 2 + 4.0 / 12), rel=1e-3)
    g = disc.gyroscopic_matrix()
    np.testing.assert_array_equal(g, -g.T)
    assert g[2, 3] == pytest.approx(disc.polar_inertia_kg_m2)


def test_global_matrices(turbine_rotor):
    rotor = turbine_rotor
    assert rotor.n_dof == 84
    np.testing.assert_allclose(rotor.mass_matrix, rotor.mass_matrix.T, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rotor.gyroscopic_matrix, -rotor.gyroscopic_matrix.T, atol=0)
    assert np.abs(rotor.gyroscopic_matrix).max() > 0.0
    np.testing.assert_allclose(
        rotor.damping_matrix, load_machine().structural_damping_s * rotor.stiffness_matrix
    )
    assert np.linalg.eigvalsh(rotor.mass_matrix).min() > 0.0
    # Gyroscopic coupling only links the x-z plane (V, Gamma) with the y-z plane (W, B).
    plane_x = np.zeros(84, dtype=bool)
    plane_x[0::4] = plane_x[3::4] = True
    g = rotor.gyroscopic_matrix
    assert not g[np.ix_(plane_x, plane_x)].any() and not g[np.ix_(~plane_x, ~plane_x)].any()
    assert rotor.dof(13, "y") == 49 and rotor.dof(1, "x") == 0 and rotor.dof(21, "ry") == 83


def test_bearing_matrices_follow_lund_convention(turbine_rotor):
    k = np.array([[6.9e7, 3.1e8], [-3.25e8, 3.6e7]])
    c = np.array([[1.3e6, -1.5e5], [-1.5e5, 1.4e6]])
    k_b, c_b = bearing_matrices(84, [LinearBearing(6, k, c)])
    x, y = turbine_rotor.dof(6, "x"), turbine_rotor.dof(6, "y")
    assert k_b[x, y] == k[0, 1] and k_b[y, x] == k[1, 0]
    assert c_b[y, y] == c[1, 1]
    assert np.count_nonzero(k_b) == 4


@pytest.fixture(scope="module")
def turbine_rotor():
    return Rotor.from_machine(load_machine())
