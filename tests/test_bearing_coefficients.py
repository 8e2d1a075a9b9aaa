"""Static equilibrium and linearized coefficients: step independence, mesh convergence, symmetry."""

from __future__ import annotations

import numpy as np
import pytest

from models.bearing.equilibrium import (
    DISPLACEMENT_STEP_RATIO,
    coefficients_at,
    linearized_coefficients,
    static_equilibrium,
)
from models.bearing.geometry import JournalBearing
from models.bearing.grid import PRODUCTION_MESH, Mesh
from models.bearing.supply import ML_MIN_PER_M3_S, SupplyFlow

BEARING = JournalBearing(0.045, 0.070, 120e-6, 0.094, 0.0, 16.2e-3, 35e-3)
LOAD_N, SPEED_HZ = 3272.8, 75.0
NOMINAL = SupplyFlow(596.3 / ML_MIN_PER_M3_S)


@pytest.fixture(scope="module")
def nominal_equilibrium():
    return static_equilibrium(BEARING, LOAD_N, SPEED_HZ, NOMINAL, PRODUCTION_MESH)


def test_equilibrium_balances_the_load(nominal_equilibrium):
    eq = nominal_equilibrium
    np.testing.assert_allclose(eq.film.force_n, [0.0, LOAD_N], atol=1e-6 * LOAD_N)
    assert eq.regime == "flooded"
    assert 0.05 < eq.eccentricity_ratio < 0.3
    assert 30.0 < eq.attitude_deg < 90.0  # displaced down and in the direction of rotation (+x)
    assert eq.eccentricity_m[0] > 0.0 > eq.eccentricity_m[1]
    assert eq.side_leakage_m3_s == pytest.approx(NOMINAL.q_m3_s, rel=1e-6)


def test_halving_the_steps_changes_no_coefficient_by_more_than_half_a_percent(
    nominal_equilibrium,
):
    args = (BEARING, nominal_equilibrium, SPEED_HZ, NOMINAL, PRODUCTION_MESH)
    k1, c1 = coefficients_at(*args)
    k2, c2 = coefficients_at(*args, step_ratio=0.5 * DISPLACEMENT_STEP_RATIO)
    np.testing.assert_allclose(k2, k1, rtol=5e-3)
    np.testing.assert_allclose(c2, c1, rtol=5e-3)


def test_full_film_damping_is_symmetric(nominal_equilibrium):
    """Pure squeeze on a frozen partition: C = W^T A^-1 W with a symmetric Poiseuille operator."""
    _, damping = coefficients_at(BEARING, nominal_equilibrium, SPEED_HZ, NOMINAL, PRODUCTION_MESH)
    assert damping[0, 1] == pytest.approx(damping[1, 0], rel=1e-9)
    assert np.all(np.linalg.eigvalsh(damping) > 0.0)  # the film dissipates


def test_production_mesh_within_one_percent_of_a_mesh_twice_as_fine():
    fine = Mesh(2 * PRODUCTION_MESH.n_circ, 2 * PRODUCTION_MESH.n_axial)
    k1, c1 = linearized_coefficients(BEARING, LOAD_N, SPEED_HZ, NOMINAL, PRODUCTION_MESH)
    k2, c2 = linearized_coefficients(BEARING, LOAD_N, SPEED_HZ, NOMINAL, fine)
    np.testing.assert_allclose(k1, k2, rtol=0.01)
    np.testing.assert_allclose(c1, c2, rtol=0.01)
