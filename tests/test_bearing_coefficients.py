"""Static equilibrium and linearized coefficients: step independence, mesh convergence, symmetry.

The step-halving and mesh-convergence checks run at every flowrate of the committed table (7 points,
50 % to 150 % of each mesh's own flooded threshold q_t, exactly as ``oilwatch bearing-table``), on
module-scoped fixtures shared by the tests.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from oilwatch.models.bearing.equilibrium import (
    DISPLACEMENT_STEP_RATIO,
    coefficients_at,
    on_flooded_threshold,
    one_sided_coefficients,
    static_equilibrium,
)
from oilwatch.models.bearing.film import solve_film
from oilwatch.models.bearing.geometry import JournalBearing
from oilwatch.models.bearing.grid import PRODUCTION_MESH, Mesh
from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S, SupplyFlow
from oilwatch.models.bearing.table import flooded_threshold

BEARING = JournalBearing(0.045, 0.070, 120e-6, 0.094, 0.0, 16.2e-3, 35e-3)
LOAD_N, SPEED_HZ = 3272.8, 75.0
NOMINAL = SupplyFlow(596.3 / ML_MIN_PER_M3_S)
TABLE_FRACTIONS = np.linspace(0.5, 1.5, 7)
THRESHOLD_NODE = 3
FINE_MESH = Mesh(2 * PRODUCTION_MESH.n_circ, 2 * PRODUCTION_MESH.n_axial)


def table_points(mesh: Mesh, guesses: list[np.ndarray] | None = None) -> list[dict]:
    """Equilibrium, K and C at the table's flowrates on ``mesh`` (as ``compute_table``: high to low).

    ``guesses``: starting positions per node (e.g. a coarser mesh's equilibria), else the previous node's.
    """
    q_t, _ = flooded_threshold(BEARING, LOAD_N, SPEED_HZ, mesh)
    points, guess = [], None
    for node in reversed(range(len(TABLE_FRACTIONS))):
        supply = SupplyFlow(q_t * TABLE_FRACTIONS[node])
        guess = guess if guesses is None else guesses[node]
        eq = static_equilibrium(BEARING, LOAD_N, SPEED_HZ, supply, mesh, initial_guess_m=guess)
        stiffness, damping = coefficients_at(BEARING, eq, SPEED_HZ, supply, mesh)
        points.append({"supply": supply, "eq": eq, "K": stiffness, "C": damping})
        guess = eq.eccentricity_m
    return points[::-1]


def free_stiffness(point: dict, mesh: Mesh, step_ratio: float) -> np.ndarray:
    """Central differences of films re-solved with a free partition (cells may switch)."""
    dx = step_ratio * BEARING.clearance_m
    eq = point["eq"]
    stiffness = np.empty((2, 2))
    for j in range(2):
        unit = np.eye(2)[j]
        forces = [
            solve_film(
                BEARING,
                SPEED_HZ,
                tuple(eq.eccentricity_m + sign * dx * unit),
                point["supply"],
                mesh=mesh,
                warm_start=eq.film,
            ).force_n
            for sign in (1.0, -1.0)
        ]
        stiffness[:, j] = -(forces[0] - forces[1]) / (2.0 * dx)
    return stiffness


def normwise(a: np.ndarray, b: np.ndarray) -> float:
    """max |a - b| relative to the largest entry of b."""
    return float(np.abs(a - b).max() / np.abs(b).max())


@pytest.fixture(scope="module")
def nominal_equilibrium():
    return static_equilibrium(BEARING, LOAD_N, SPEED_HZ, NOMINAL, PRODUCTION_MESH)


@pytest.fixture(scope="module")
def production_points():
    return table_points(PRODUCTION_MESH)


@pytest.fixture(scope="module")
def fine_points(production_points):
    return table_points(FINE_MESH, [p["eq"].eccentricity_m for p in production_points])


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


@pytest.mark.slow
@pytest.mark.parametrize("node", range(len(TABLE_FRACTIONS)))
def test_halving_the_steps_at_every_table_flowrate(production_points, node):
    """Held-partition differences are smooth: halving the step changes K by ~1e-5 relative."""
    point = production_points[node]
    k2, c2 = coefficients_at(
        BEARING,
        point["eq"],
        SPEED_HZ,
        point["supply"],
        PRODUCTION_MESH,
        step_ratio=0.5 * DISPLACEMENT_STEP_RATIO,
    )
    np.testing.assert_allclose(k2, point["K"], rtol=5e-3)
    np.testing.assert_allclose(c2, point["C"], rtol=5e-3)
    np.testing.assert_allclose(k2, point["K"], rtol=1e-4)
    np.testing.assert_allclose(c2, point["C"], rtol=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("node", [n for n in range(len(TABLE_FRACTIONS)) if n != THRESHOLD_NODE])
def test_held_stiffness_agrees_with_free_resolves_at_moderate_steps(production_points, node):
    """Free re-solves at 0.5 % of c (cells switching) scatter about the held derivative.

    The scatter is the discrete film's piecewise structure (cavitation boundaries advance cell by
    cell): up to 0.8 % normwise and 1.8 % per entry on the production mesh.
    """
    point = production_points[node]
    free = free_stiffness(point, PRODUCTION_MESH, 5e-3)
    assert normwise(free, point["K"]) < 0.01
    np.testing.assert_allclose(free, point["K"], rtol=0.02)


@pytest.mark.slow
def test_threshold_node_takes_the_mean_of_the_one_sided_limits(production_points):
    """At q_t the groove is just full: starved on one side, flooded on the other (a real kink)."""
    point = production_points[THRESHOLD_NODE]
    assert on_flooded_threshold(point["eq"].film, point["supply"], SPEED_HZ)
    assert not any(
        on_flooded_threshold(p["eq"].film, p["supply"], SPEED_HZ)
        for n, p in enumerate(production_points)
        if n != THRESHOLD_NODE
    )
    sides = one_sided_coefficients(BEARING, point["eq"], SPEED_HZ, point["supply"], PRODUCTION_MESH)
    starved, flooded = sides["starved"][0], sides["flooded"][0]
    assert normwise(starved, flooded) > 0.03  # the stiffness jumps across q_t
    np.testing.assert_allclose(point["K"], 0.5 * (starved + flooded), rtol=1e-12)
    # Symmetric free differences straddle the kink: they see the mean, not either side.
    free = free_stiffness(point, PRODUCTION_MESH, 5e-3)
    assert normwise(free, point["K"]) < 0.01
    assert normwise(free, starved) > 0.02 and normwise(free, flooded) > 0.02


@pytest.mark.slow
def test_squeeze_everywhere_damping_is_the_small_step_limit_of_free_resolves():
    """squeeze="everywhere" re-solves the quasi-steady film: on the held partition it is smooth in
    the velocity, and free re-solves approach it as the velocity step shrinks (3 % off at 1e-2)."""
    eq = static_equilibrium(BEARING, LOAD_N, SPEED_HZ, NOMINAL, PRODUCTION_MESH, squeeze="everywhere")
    args = (BEARING, eq, SPEED_HZ, NOMINAL, PRODUCTION_MESH)
    _, c1 = coefficients_at(*args, squeeze="everywhere")
    _, c2 = coefficients_at(*args, squeeze="everywhere", step_ratio=0.5 * DISPLACEMENT_STEP_RATIO)
    np.testing.assert_allclose(c2, c1, rtol=1e-4)
    dv = 3e-4 * BEARING.clearance_m * 2.0 * math.pi * SPEED_HZ
    free = np.empty((2, 2))
    for j in range(2):
        forces = [
            solve_film(
                BEARING,
                SPEED_HZ,
                tuple(eq.eccentricity_m),
                NOMINAL,
                velocity_m_s=tuple(sign * dv * np.eye(2)[j]),
                mesh=PRODUCTION_MESH,
                squeeze="everywhere",
                warm_start=eq.film,
            ).force_n
            for sign in (1.0, -1.0)
        ]
        free[:, j] = -(forces[0] - forces[1]) / (2.0 * dv)
    assert normwise(free, c1) < 0.005


def test_full_film_damping_is_symmetric(nominal_equilibrium):
    """Pure squeeze on a frozen partition: C = W^T A^-1 W with a symmetric Poiseuille operator."""
    _, damping = coefficients_at(BEARING, nominal_equilibrium, SPEED_HZ, NOMINAL, PRODUCTION_MESH)
    assert damping[0, 1] == pytest.approx(damping[1, 0], rel=1e-9)
    assert np.all(np.linalg.eigvalsh(damping) > 0.0)  # the film dissipates


@pytest.mark.slow
@pytest.mark.parametrize("node", range(len(TABLE_FRACTIONS)))
def test_table_coefficients_within_one_percent_of_a_mesh_twice_as_fine(production_points, fine_points, node):
    coarse, fine = production_points[node], fine_points[node]
    assert math.isclose(coarse["supply"].q_m3_s, fine["supply"].q_m3_s, rel_tol=1e-3)  # each mesh's own q_t
    np.testing.assert_allclose(coarse["eq"].eccentricity_m, fine["eq"].eccentricity_m, rtol=2e-3)
    # The criterion: within 1 % of the matrix's largest entry (entries differ 10-fold in C).
    assert normwise(coarse["K"], fine["K"]) < 0.01
    assert normwise(coarse["C"], fine["C"]) < 0.01
    # Entry by entry the known miss (up to 2.6 % on Kyy, 1.4 % on Cxy; see grid.PRODUCTION_MESH).
    np.testing.assert_allclose(coarse["K"], fine["K"], rtol=0.03)
    np.testing.assert_allclose(coarse["C"], fine["C"], rtol=0.02)
