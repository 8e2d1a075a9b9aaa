"""A bearing's static load in any direction: the equilibrium and its K, C (bearing level only).

References that are not the implementation again:

* rotational invariance: turning the load AND every groove by delta is the same physical bearing
  seen turned, so the equilibrium must turn by delta, K and C become R K R^T and R C R^T, and the
  supply flow, groove pressure and attitude stay;
* Ocvirk's short-bearing numbers (REFERENCE.md) for a load that is not along -y;
* the default (-y) against the -y solve's figures, pinned (a regression check, not a reference).

Why the invariance tolerances are solver tolerances, not mesh-size ones: the film grid is anchored
to the first groove (psi = 0 at its upstream edge, ``grid.film_grid``), so turning every groove by
delta turns every cell face by exactly delta whether or not delta is a multiple of a cell angle
(:func:`test_the_film_grid_turns_with_the_grooves`). The turned discrete problem is then the same
problem in turned coordinates, and what is left is

* the Newton stopping test |F - F0| < 1e-9 W in each solve: |e' - R e| <= 2e-9 W / sigma_min(K);
* the central differences of K, taken along x and y, i.e. along directions turned by -delta
  relative to the base problem's: their O(step^2) truncation error is not covariant. Halving the
  step changes K by < 1e-5 of its largest entry (equilibrium.DISPLACEMENT_STEP_RATIO), so the
  truncation error is below about 1.5e-5; tolerance 5e-5;
* C is the exact central difference of a response linear in the velocity (``film`` module), so it
  only feels the 1e-9-relative change of position: tolerance 1e-7.

Observed on the 72 x 24 mesh (three bearing/supply cases, four deltas, 0.13-0.17 s a solve):
|e' - R e| <= 5e-11 c, attitude <= 2.1e-8 deg, K <= 4.8e-6, C <= 1.2e-10, supply flow <= 1.1e-13
relative, groove pressure <= 6.1e-5 Pa (1e-11 of mu Omega R^2 / c^2), whichever the delta.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from oilwatch.models.bearing.equilibrium import (
    attitude_angle_deg,
    coefficients_at,
    film_force_at_equilibrium,
    linearized_coefficients,
    static_equilibrium,
)
from oilwatch.models.bearing.geometry import DOWNWARD_LOAD_RAD, AxialGroove, JournalBearing
from oilwatch.models.bearing.grid import Mesh, film_grid
from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S, SupplyFlow, SupplyPressure
from oilwatch.models.validation import InputError

R, L, C, MU = 0.045, 0.070, 120e-6, 0.094
LOAD_N, SPEED_HZ = 3272.8, 75.0
MESH = Mesh(72, 24)
ONE_GROOVE = JournalBearing(R, L, C, MU, 0.0, 16.2e-3, 35e-3)
# Two grooves near the horizontal (bearing angles +-86 deg), as a gearbox bearing may have.
TWO_GROOVES = JournalBearing(R, L, C, MU, 1.5, 10e-3, 35e-3, more_grooves=(AxialGroove(-1.5, 10e-3, 35e-3),))
CASES = {
    "flooded flow-fed": (ONE_GROOVE, SupplyFlow(596.3 / ML_MIN_PER_M3_S)),
    "starved flow-fed": (ONE_GROOVE, SupplyFlow(200.0 / ML_MIN_PER_M3_S)),
    "pressure-fed two grooves": (TWO_GROOVES, SupplyPressure(1.0e5)),
}
# On the 72 x 24 mesh the one-groove bearing has 4 groove cells of 0.09 rad and 68 land cells of
# 0.0871 rad: 10 land cells is a multiple of a cell angle, the others are not.
LAND_CELL_RAD = (2.0 * math.pi - 16.2e-3 / R) / 68
DELTAS = {
    "10 land cells": 10.0 * LAND_CELL_RAD,
    "half a cell": 0.5 * LAND_CELL_RAD,
    "1 rad": 1.0,
    "-2.3 rad": -2.3,
}


def turned(bearing: JournalBearing, delta: float) -> JournalBearing:
    """The bearing with every groove turned by ``delta`` [rad] in the direction of rotation."""
    return dataclasses.replace(
        bearing,
        groove_angle_rad=bearing.groove_angle_rad + delta,
        more_grooves=tuple(
            dataclasses.replace(g, angle_rad=g.angle_rad + delta) for g in bearing.more_grooves
        ),
    )


def rotation(delta: float) -> np.ndarray:
    """The (x, y) rotation by ``delta``: a bearing angle grows with the polar angle (grid module)."""
    return np.array([[math.cos(delta), -math.sin(delta)], [math.sin(delta), math.cos(delta)]])


def normwise(a: np.ndarray, b: np.ndarray) -> float:
    """max |a - b| relative to the largest entry of b."""
    return float(np.abs(a - b).max() / np.abs(b).max())


@pytest.fixture(scope="module")
def downward():
    """Equilibrium, K and C of each case under the default load along -y."""
    solved = {}
    for name, (bearing, supply) in CASES.items():
        eq = static_equilibrium(bearing, LOAD_N, SPEED_HZ, supply, MESH)
        solved[name] = (eq, *coefficients_at(bearing, eq, SPEED_HZ, supply, MESH))
    return solved


def test_the_film_grid_turns_with_the_grooves():
    """The reason the invariance holds to solver precision for any delta (module docstring)."""
    for bearing, _ in CASES.values():
        base = film_grid(bearing, MESH)
        for delta in DELTAS.values():
            grid = film_grid(turned(bearing, delta), MESH)
            np.testing.assert_allclose(grid.psi_faces_rad, base.psi_faces_rad, rtol=0.0, atol=1e-12)
            np.testing.assert_allclose(
                grid.alpha_faces_rad, base.alpha_faces_rad + delta, rtol=0.0, atol=1e-12
            )
            assert np.array_equal(grid.in_groove, base.in_groove)


@pytest.mark.parametrize("delta_name", DELTAS)
@pytest.mark.parametrize("case", CASES)
def test_turning_load_and_grooves_together_turns_the_equilibrium_and_the_coefficients(
    downward, case, delta_name
):
    bearing, supply = CASES[case]
    delta = DELTAS[delta_name]
    eq0, k0, c0 = downward[case]
    bearing_turned = turned(bearing, delta)
    eq = static_equilibrium(
        bearing_turned, LOAD_N, SPEED_HZ, supply, MESH, load_angle_rad=DOWNWARD_LOAD_RAD + delta
    )
    stiffness, damping = coefficients_at(bearing_turned, eq, SPEED_HZ, supply, MESH)
    rot = rotation(delta)

    # Both solves stop at |F - F0| < 1e-9 W: each position is within 1e-9 W / sigma_min(K) of its root.
    position_tol = 2e-9 * LOAD_N / np.linalg.svd(k0, compute_uv=False).min()
    assert np.linalg.norm(eq.eccentricity_m - rot @ eq0.eccentricity_m) < position_tol
    assert eq.eccentricity_ratio == pytest.approx(eq0.eccentricity_ratio, rel=1e-6)
    assert eq.attitude_deg == pytest.approx(
        eq0.attitude_deg, abs=math.degrees(position_tol / np.linalg.norm(eq0.eccentricity_m))
    )
    assert eq.load_angle_rad == DOWNWARD_LOAD_RAD + delta
    np.testing.assert_allclose(eq.film.force_n, rot @ eq0.film.force_n, rtol=0.0, atol=2e-9 * LOAD_N)
    assert eq.regime == eq0.regime
    assert eq.supply_flow_m3_s == pytest.approx(eq0.supply_flow_m3_s, rel=1e-7)
    p_ref = MU * 2.0 * math.pi * SPEED_HZ * (R / C) ** 2
    assert eq.supply_pressure_pa == pytest.approx(eq0.supply_pressure_pa, rel=0.0, abs=1e-8 * p_ref)
    assert normwise(stiffness, rot @ k0 @ rot.T) < 5e-5
    assert normwise(damping, rot @ c0 @ rot.T) < 1e-7


# REFERENCE.md: Ocvirk (short bearing, half film) for the paper's bearing made 8 times shorter
# under a load 8^3 times smaller (as tests/test_bearing_limits.py), attitude from the load direction.
OCVIRK_RATIO, OCVIRK_ATTITUDE_DEG = 0.0863, 83.7
LINE_FEED_M = 0.5e-3


def test_short_bearing_attitude_from_a_sideways_load_is_ocvirks():
    """Load along +x turned 10 deg downwards (bearing angle 260 deg, a gear-mesh force plus weight).

    The short-bearing theory has no groove and no preferred direction: eccentricity and attitude
    from the load depend only on the Sommerfeld number, as for the -y load of
    test_bearing_limits.py. The full-length feed line at ambient pressure sits at the thickest film
    of that equilibrium (bearing angle = load angle + attitude - 180 deg), opposite the loaded zone,
    where it floods the converging film without pressurizing it. Tolerances as in
    test_bearing_limits.py: 1.5 % on the ratio, 0.5 deg on the attitude (the neglected
    circumferential flow, of order (L/D)^2).
    """
    shrink = 8.0
    length = L / shrink
    load_angle = math.radians(260.0)
    feed = load_angle + math.radians(OCVIRK_ATTITUDE_DEG) - math.pi
    bearing = JournalBearing(R, length, C, MU, feed, LINE_FEED_M, length)
    eq = static_equilibrium(
        bearing, LOAD_N / shrink**3, SPEED_HZ, SupplyPressure(0.0), Mesh(120, 12), load_angle_rad=load_angle
    )
    assert eq.eccentricity_ratio == pytest.approx(OCVIRK_RATIO, rel=0.015)
    assert eq.attitude_deg == pytest.approx(OCVIRK_ATTITUDE_DEG, abs=0.5)
    # The journal moves 83.7 deg ahead of the load (bearing angle 343.7 deg): up and towards +x.
    assert eq.eccentricity_m[0] > 0.0 and eq.eccentricity_m[1] > 0.0


# The flooded flow-fed case under a load along -y on the 72 x 24 mesh, as the solver gives it without a
# load angle: the default must keep giving it. Pinned to 1e-12, not to the bit: another BLAS or SuperLU
# build may differ in the last bit.
DOWNWARD_E_M = [1.3634604008269512e-05, -6.015849780774163e-06]
DOWNWARD_ATTITUDE_DEG = 66.19200468524792
DOWNWARD_K = [[207001522.85060358, 165634898.35607752], [-127546437.53023627, 66141726.91151527]]
DOWNWARD_C = [[534949.9828265809, -218618.16757815148], [-218618.1675781546, 1145260.083502886]]


def test_the_default_load_is_the_downward_load(downward):
    eq, stiffness, damping = downward["flooded flow-fed"]
    np.testing.assert_allclose(eq.eccentricity_m, DOWNWARD_E_M, rtol=1e-12)
    assert eq.attitude_deg == pytest.approx(DOWNWARD_ATTITUDE_DEG, rel=1e-12)
    np.testing.assert_allclose(stiffness, DOWNWARD_K, rtol=1e-12)
    np.testing.assert_allclose(damping, DOWNWARD_C, rtol=1e-12)
    assert eq.load_angle_rad == math.pi
    # The default's Newton target is exactly (0, +W), without a -0.0 or a 1e-16 x-part.
    target = film_force_at_equilibrium(LOAD_N)
    assert target.tobytes() == np.array([0.0, LOAD_N]).tobytes()
    # Naming the default gives the same bits.
    bearing, supply = CASES["flooded flow-fed"]
    named = static_equilibrium(bearing, LOAD_N, SPEED_HZ, supply, MESH, load_angle_rad=math.pi)
    assert named.eccentricity_m.tobytes() == eq.eccentricity_m.tobytes()
    assert named.attitude_deg == eq.attitude_deg
    assert named.film.pressure_pa.tobytes() == eq.film.pressure_pa.tobytes()


def test_without_an_angle_the_solve_takes_the_bearings_own_load_direction():
    bearing, supply = CASES["flooded flow-fed"]
    angle = math.radians(150.0)
    own = static_equilibrium(
        dataclasses.replace(bearing, load_angle_rad=angle), LOAD_N, SPEED_HZ, supply, MESH
    )
    named = static_equilibrium(bearing, LOAD_N, SPEED_HZ, supply, MESH, load_angle_rad=angle)
    assert own.load_angle_rad == angle
    assert own.eccentricity_m.tobytes() == named.eccentricity_m.tobytes()
    assert own.attitude_deg == named.attitude_deg
    # an explicit angle still wins over the bearing's
    turned = dataclasses.replace(bearing, load_angle_rad=angle)
    down = static_equilibrium(turned, LOAD_N, SPEED_HZ, supply, MESH, load_angle_rad=math.pi)
    np.testing.assert_allclose(down.eccentricity_m, DOWNWARD_E_M, rtol=1e-12)


def test_film_force_opposes_the_load_in_the_bearing_angle_convention():
    """Bearing angle 0 is the top (+y) and grows with the rotation (towards -x): a load along +x is
    at 270 deg and the film pushes back along -x."""
    for angle, film_direction in ((math.pi, (0.0, 1.0)), (0.0, (0.0, -1.0)), (1.5 * math.pi, (-1.0, 0.0))):
        np.testing.assert_allclose(
            film_force_at_equilibrium(2.0, angle), 2.0 * np.array(film_direction), atol=1e-15
        )
    # Attitude from a +x load of a journal displaced along +y: a quarter turn ahead in the rotation.
    assert attitude_angle_deg(np.array([0.0, 1e-5]), 1.5 * math.pi) == pytest.approx(90.0)


@pytest.mark.parametrize("angle", [math.nan, math.inf, -math.inf, "down"])
def test_a_non_finite_load_angle_is_refused_in_one_line(angle):
    bearing, supply = CASES["flooded flow-fed"]
    for solve in (static_equilibrium, linearized_coefficients):
        with pytest.raises(InputError, match="load_angle_rad must be") as error:
            solve(bearing, LOAD_N, SPEED_HZ, supply, MESH, load_angle_rad=angle)
        assert "\n" not in str(error.value)
