"""Static equilibrium of the journal under a vertical load, and the linearized film coefficients.

Conventions (team contract, Lund 1987): the load pushes the journal along -y with magnitude
``load_n``; at equilibrium the film force is F0 = (0, +load_n). Linearized about it,
F = F0 - K (r - r0) - C r_dot, i.e. K_ij = -dF_i/dx_j and C_ij = -dF_i/dxdot_j with i, j in (x, y).
The attitude angle is the angle from the load direction (-y) to the journal displacement, positive
in the direction of rotation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..validation import InputError, require_positive
from .film import MAX_ECCENTRICITY_RATIO, FilmSolution, solve_film
from .geometry import JournalBearing
from .grid import Mesh
from .supply import Supply

DISPLACEMENT_STEP_RATIO = 1.0e-2
"""Central-difference displacement step as a fraction of the radial clearance.

The discrete film force is piecewise smooth in the journal position: volumes switch between full
and cavitated as the cavitation boundaries move, so the slope of each smooth piece differs from
the mesh-independent envelope by about 1 % on the production mesh, and steps below about 0.7 % of
c sample single pieces. Larger steps carry the truncation error step^2 F3 / 6 of central
differences. At 1 % of c, halving the step changes the stiffness by < 0.5 % at the nominal flow
(tested), 0.1-1 % across the table, and 1.8 % at the q_t node, where the groove is just full and
the force has a real kink (starved on one side, flooded on the other).
"""


@dataclass(frozen=True, eq=False)
class Equilibrium:
    """Static equilibrium of the journal.

    Attributes: eccentricity_m (2,) journal centre (e_x, e_y) [m]; eccentricity_ratio [-];
    attitude_deg [deg]; supply_pressure_pa groove pressure [Pa]; supply_flow_m3_s [m^3/s];
    side_leakage_m3_s [m^3/s]; regime "starved" or "flooded"; iterations Newton steps;
    film the film solution at equilibrium.
    """

    eccentricity_m: np.ndarray
    eccentricity_ratio: float
    attitude_deg: float
    supply_pressure_pa: float
    supply_flow_m3_s: float
    side_leakage_m3_s: float
    regime: str
    iterations: int
    film: FilmSolution = field(repr=False)


def attitude_angle_deg(eccentricity_m: np.ndarray) -> float:
    """Angle from the load direction (-y) to the displacement, positive with the rotation [deg]."""
    angle = math.degrees(math.atan2(eccentricity_m[1], eccentricity_m[0])) + 90.0
    return (angle + 180.0) % 360.0 - 180.0


def _initial_guess(bearing: JournalBearing) -> np.ndarray:
    """A lightly loaded journal: eccentricity ratio 0.1 at an attitude of 60 deg."""
    angle = math.radians(60.0 - 90.0)
    return 0.1 * bearing.clearance_m * np.array([math.cos(angle), math.sin(angle)])


def static_equilibrium(
    bearing: JournalBearing,
    load_n: float,
    speed_hz: float,
    supply: Supply,
    mesh: Mesh | None = None,
    *,
    squeeze: str = "full-film",
    initial_guess_m: np.ndarray | None = None,
    force_tolerance: float = 1e-9,
    max_iterations: int = 40,
) -> Equilibrium:
    """Journal position where the film carries ``load_n`` [N] (along -y) at ``speed_hz`` [Hz].

    Newton's method on (e_x, e_y) with a forward-difference Jacobian (warm-started film solves) and
    step halving; converged when |F - F0| < force_tolerance * load_n.
    """
    load = require_positive("load_n", load_n, "N")
    require_positive("speed_hz", speed_hz, "Hz")
    c = bearing.clearance_m
    target = np.array([0.0, load])
    e = _initial_guess(bearing) if initial_guess_m is None else np.asarray(initial_guess_m, float)
    film = solve_film(bearing, speed_hz, tuple(e), supply, mesh=mesh, squeeze=squeeze)
    residual = film.force_n - target
    step = 1e-4 * c
    for iteration in range(1, max_iterations + 1):
        if np.linalg.norm(residual) < force_tolerance * load:
            return _equilibrium(e, film, iteration - 1, c)
        jac = np.empty((2, 2))
        for j in range(2):
            de = np.zeros(2)
            de[j] = step
            moved = solve_film(
                bearing,
                speed_hz,
                tuple(e + de),
                supply,
                mesh=mesh,
                squeeze=squeeze,
                warm_start=film,
            )
            jac[:, j] = (moved.force_n - film.force_n) / step
        delta = -np.linalg.solve(jac, residual)
        limit = 0.2 * c
        if np.linalg.norm(delta) > limit:
            delta *= limit / np.linalg.norm(delta)
        for _ in range(12):
            trial = e + delta
            if np.hypot(*trial) / c < MAX_ECCENTRICITY_RATIO - 0.03:
                trial_film = solve_film(
                    bearing,
                    speed_hz,
                    tuple(trial),
                    supply,
                    mesh=mesh,
                    squeeze=squeeze,
                    warm_start=film,
                )
                trial_residual = trial_film.force_n - target
                if np.linalg.norm(trial_residual) < np.linalg.norm(residual):
                    break
            delta *= 0.5
        else:
            raise InputError(
                f"no static equilibrium found for load_n={load:g} N at speed_hz={speed_hz:g} with "
                f"{supply}: the film cannot carry the load below eccentricity ratio "
                f"{MAX_ECCENTRICITY_RATIO}"
            )
        e, film, residual = trial, trial_film, trial_residual
    raise RuntimeError(
        f"static equilibrium did not converge in {max_iterations} Newton steps "
        f"(force residual {np.linalg.norm(residual):.3g} N)"
    )


def _equilibrium(e: np.ndarray, film: FilmSolution, iterations: int, c: float) -> Equilibrium:
    return Equilibrium(
        eccentricity_m=e.copy(),
        eccentricity_ratio=float(np.hypot(*e) / c),
        attitude_deg=attitude_angle_deg(e),
        supply_pressure_pa=film.supply_pressure_pa,
        supply_flow_m3_s=film.supply_flow_m3_s,
        side_leakage_m3_s=film.side_leakage_m3_s,
        regime=film.regime,
        iterations=iterations,
        film=film,
    )


def coefficients_at(
    bearing: JournalBearing,
    equilibrium: Equilibrium,
    speed_hz: float,
    supply: Supply,
    mesh: Mesh | None = None,
    *,
    squeeze: str = "full-film",
    step_ratio: float = DISPLACEMENT_STEP_RATIO,
) -> tuple[np.ndarray, np.ndarray]:
    """K (2, 2) [N/m] and C (2, 2) [N s/m] at ``equilibrium`` by central differences.

    Stiffness: steady films re-solved at e0 +- step_ratio * c (the cavitation boundaries move:
    quasi-static stiffness), see :data:`DISPLACEMENT_STEP_RATIO`. Velocity steps are ``step_ratio * c *
    Omega``. With ``squeeze="full-film"`` the velocity response is taken on the equilibrium
    partition with the film content frozen (see :mod:`models.bearing.film`); it is then linear in
    the velocity and the central difference is exact, the small-velocity limit of the full
    frozen-content response. With ``squeeze="everywhere"`` the quasi-steady film is re-solved.
    """
    dx = step_ratio * bearing.clearance_m
    dv = dx * 2.0 * math.pi * speed_hz
    e0 = equilibrium.eccentricity_m
    base = equilibrium.film
    stiffness = np.empty((2, 2))
    damping = np.empty((2, 2))
    for j in range(2):
        unit = np.zeros(2)
        unit[j] = 1.0
        forces = [
            solve_film(
                bearing,
                speed_hz,
                tuple(e0 + sign * dx * unit),
                supply,
                mesh=mesh,
                squeeze=squeeze,
                warm_start=base,
            ).force_n
            for sign in (1.0, -1.0)
        ]
        stiffness[:, j] = -(forces[0] - forces[1]) / (2.0 * dx)
        forces = [
            solve_film(
                bearing,
                speed_hz,
                tuple(e0),
                supply,
                velocity_m_s=tuple(sign * dv * unit),
                mesh=mesh,
                squeeze=squeeze,
                warm_start=base,
                hold_partition=True,
            ).force_n
            for sign in (1.0, -1.0)
        ]
        damping[:, j] = -(forces[0] - forces[1]) / (2.0 * dv)
    return stiffness, damping


def linearized_coefficients(
    bearing: JournalBearing,
    load_n: float,
    speed_hz: float,
    supply: Supply,
    mesh: Mesh | None = None,
    *,
    squeeze: str = "full-film",
    step_ratio: float = DISPLACEMENT_STEP_RATIO,
) -> tuple[np.ndarray, np.ndarray]:
    """K (2, 2) [N/m] and C (2, 2) [N s/m] at the static equilibrium (Lund's convention)."""
    eq = static_equilibrium(bearing, load_n, speed_hz, supply, mesh, squeeze=squeeze)
    return coefficients_at(bearing, eq, speed_hz, supply, mesh, squeeze=squeeze, step_ratio=step_ratio)
