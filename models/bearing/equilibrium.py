"""Static equilibrium of the journal under a static load, and the linearized film coefficients.

Conventions (team contract, Lund 1987): the load pushes the journal with magnitude ``load_n`` along
the bearing angle ``load_angle_rad`` (the angle convention of :mod:`oilwatch.models.bearing.grid`:
from the top, +y, in the direction of rotation); by default the bearing's own
(``JournalBearing.load_angle_rad``, pi, -y, the weight, unless its machine file gives another), where the film
force at equilibrium is F0 = (0, +load_n). Linearized about it, F = F0 - K (r - r0) - C r_dot, i.e.
K_ij = -dF_i/dx_j and C_ij = -dF_i/dxdot_j with i, j in (x, y) whatever the load direction.
The attitude angle is the angle from the load direction to the journal displacement, positive in
the direction of rotation.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..validation import InputError, require_finite, require_positive
from .film import MAX_ECCENTRICITY_RATIO, FilmSolution, solve_film
from .geometry import DOWNWARD_LOAD_RAD, JournalBearing
from .grid import Mesh
from .supply import Supply, SupplyFlow

DISPLACEMENT_STEP_RATIO = 1.0e-3
"""Central-difference displacement step as a fraction of the radial clearance.

The stiffness is the derivative of the discrete film force along the smooth solution branch
through the equilibrium: the film is re-solved at e0 +- step with the equilibrium's full/cavitated
partition held (``solve_film(hold_partition=True)``), see :func:`coefficients_at`. That branch is
smooth, so the central difference converges as step^2: halving 1e-3 c changes no stiffness by
more than about 1e-5 relative across the table (tested at every table flowrate).
"""

THRESHOLD_TOLERANCE = 1.0e-9
"""Groove fill 1 - theta_g or pressure p_g / (mu Omega R^2 / c^2) below which the groove is taken
to sit exactly on the flooded threshold (the table's q_t node): see :func:`coefficients_at`."""

GROOVE_SIDES = ("starved", "flooded")


@dataclass(frozen=True, eq=False)
class Equilibrium:
    """Static equilibrium of the journal.

    Attributes: eccentricity_m (2,) journal centre (e_x, e_y) [m]; eccentricity_ratio [-];
    attitude_deg [deg]; supply_pressure_pa groove pressure [Pa]; supply_flow_m3_s [m^3/s];
    side_leakage_m3_s [m^3/s]; regime "starved" or "flooded"; iterations Newton steps;
    film the film solution at equilibrium; load_angle_rad the bearing angle the load points along
    [rad] (pi: -y), from which ``attitude_deg`` is measured.
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
    load_angle_rad: float = DOWNWARD_LOAD_RAD


def attitude_angle_deg(eccentricity_m: np.ndarray, load_angle_rad: float = DOWNWARD_LOAD_RAD) -> float:
    """Angle from the load direction to the displacement, positive with the rotation [deg].

    Parameters
    ----------
    eccentricity_m : (2,) journal centre (e_x, e_y) [m].
    load_angle_rad : bearing angle the load points along [rad]; pi (the default) is -y.
    """
    # Measured from -y and turned by the load's offset from -y: the offset is exactly 0.0 for the
    # default, so a downward load gives the -y figure bit for bit.
    offset = math.degrees(load_angle_rad - DOWNWARD_LOAD_RAD)
    angle = math.degrees(math.atan2(eccentricity_m[1], eccentricity_m[0])) + 90.0 - offset
    return (angle + 180.0) % 360.0 - 180.0


def film_force_at_equilibrium(load_n: float, load_angle_rad: float = DOWNWARD_LOAD_RAD) -> np.ndarray:
    """F0 (2,) [N]: the film force that balances ``load_n`` [N] pointing along ``load_angle_rad``.

    The load points along the bearing angle beta, i.e. the unit vector (-sin beta, cos beta); the film
    pushes back with F0 = load_n (sin beta, -cos beta). Written as the turn of (0, load_n) by
    beta - pi so that the default is exactly (0, load_n): sin(pi) is 1.2e-16, not 0.
    """
    turn = load_angle_rad - DOWNWARD_LOAD_RAD
    # + 0.0 makes the default's -0.0 a plain 0.0, the (0, load_n) target of a downward load
    return np.array([-load_n * math.sin(turn) + 0.0, load_n * math.cos(turn)])


def film_forces_at_equilibrium(loads_n, load_angles_rad) -> np.ndarray:
    """F0 (n, 2) [N] of n bearings (:func:`film_force_at_equilibrium` of each load and its direction)."""
    forces = [film_force_at_equilibrium(w, a) for w, a in zip(loads_n, load_angles_rad, strict=True)]
    return np.array(forces).reshape(-1, 2)


def _initial_guess(bearing: JournalBearing, load_angle_rad: float) -> np.ndarray:
    """A lightly loaded journal: eccentricity ratio 0.1 at an attitude of 60 deg from the load."""
    angle = math.radians(60.0 - 90.0) + (load_angle_rad - DOWNWARD_LOAD_RAD)
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
    load_angle_rad: float | None = None,
) -> Equilibrium:
    """Journal position where the film carries ``load_n`` [N] at ``speed_hz`` [Hz].

    Parameters
    ----------
    bearing, load_n, speed_hz, supply, mesh, squeeze : the bearing, the load's magnitude [N], the
        speed [Hz], the oil supply, the mesh (production mesh when None) and the squeeze treatment.
    initial_guess_m : (2,) starting journal centre [m]; eccentricity ratio 0.1 at an attitude of
        60 deg from the load when None.
    force_tolerance : convergence when |F - F0| < force_tolerance * load_n.
    max_iterations : Newton steps before a RuntimeError.
    load_angle_rad : bearing angle the load on the journal points along [rad] (from the top, +y, in
        the direction of rotation); None (the default) takes the bearing's own,
        ``bearing.load_angle_rad`` (pi, -y, unless its machine file gives another).

    Returns
    -------
    Equilibrium, its attitude measured from the load direction.

    Notes
    -----
    Newton's method on (e_x, e_y) towards the film force F0 that opposes the load
    (:func:`film_force_at_equilibrium`), with a forward-difference Jacobian taken on the current
    film's partition (one sparse solve per column, the derivative of the discrete force) and step
    halving. Any load direction is solved as it is, on the bearing's own grooves: nothing is rotated,
    so the film sees the grooves where they are relative to the load.
    """
    load = require_positive("load_n", load_n, "N")
    require_positive("speed_hz", speed_hz, "Hz")
    load_angle = require_finite(
        "load_angle_rad", bearing.load_angle_rad if load_angle_rad is None else load_angle_rad
    )
    c = bearing.clearance_m
    target = film_force_at_equilibrium(load, load_angle)
    e = _initial_guess(bearing, load_angle) if initial_guess_m is None else np.asarray(initial_guess_m, float)
    film = solve_film(bearing, speed_hz, tuple(e), supply, mesh=mesh, squeeze=squeeze)
    residual = film.force_n - target
    step = 1e-4 * c
    for iteration in range(1, max_iterations + 1):
        if np.linalg.norm(residual) < force_tolerance * load:
            return _equilibrium(e, film, iteration - 1, c, load_angle)
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
                hold_partition=True,
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


def _equilibrium(
    e: np.ndarray, film: FilmSolution, iterations: int, c: float, load_angle_rad: float
) -> Equilibrium:
    return Equilibrium(
        eccentricity_m=e.copy(),
        eccentricity_ratio=float(np.hypot(*e) / c),
        attitude_deg=attitude_angle_deg(e, load_angle_rad),
        supply_pressure_pa=film.supply_pressure_pa,
        supply_flow_m3_s=film.supply_flow_m3_s,
        side_leakage_m3_s=film.side_leakage_m3_s,
        regime=film.regime,
        iterations=iterations,
        film=film,
        load_angle_rad=load_angle_rad,
    )


def on_flooded_threshold(film: FilmSolution, supply: Supply, speed_hz: float) -> bool:
    """True when a flow-fed groove is just full at zero gauge pressure (theta_g = 1, p_g = 0).

    ``speed_hz`` [Hz] sets the pressure scale mu Omega R^2 / c^2 of :data:`THRESHOLD_TOLERANCE`.
    """
    if not isinstance(supply, SupplyFlow):
        return False
    g = film.grid.groove_node
    bearing = film.grid.bearing
    omega = 2.0 * math.pi * speed_hz
    p_ref = bearing.viscosity_pa_s * omega * bearing.radius_m**2 / bearing.clearance_m**2
    if film.full[g]:
        return film.supply_pressure_pa <= THRESHOLD_TOLERANCE * p_ref
    return film.groove_fill_fraction >= 1.0 - THRESHOLD_TOLERANCE


def one_sided_coefficients(
    bearing: JournalBearing,
    equilibrium: Equilibrium,
    speed_hz: float,
    supply: Supply,
    mesh: Mesh | None = None,
    *,
    squeeze: str = "full-film",
    step_ratio: float = DISPLACEMENT_STEP_RATIO,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{"starved": (K, C), "flooded": (K, C)}: the two one-sided limits on the flooded threshold.

    Only for an equilibrium on the threshold (:func:`on_flooded_threshold`): the groove partition is
    set to cavitated (starved branch, theta_g free) or full (flooded branch, p_g free) and the
    coefficients are taken on each branch.
    """
    if not on_flooded_threshold(equilibrium.film, supply, speed_hz):
        raise InputError(
            "one_sided_coefficients needs an equilibrium on the flooded threshold (theta_g = 1, p_g = 0)"
        )
    g = equilibrium.film.grid.groove_node
    sides = {}
    for side in GROOVE_SIDES:
        full = equilibrium.film.full.copy()
        full[g] = side == "flooded"
        film = dataclasses.replace(equilibrium.film, full=full)
        sides[side] = _branch_coefficients(
            bearing, equilibrium.eccentricity_m, film, speed_hz, supply, mesh, squeeze, step_ratio
        )
    return sides


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

    Stiffness: films re-solved at e0 +- step_ratio * c with the equilibrium's full/cavitated
    partition held. The discrete problem is a complementarity problem: wherever no volume switches,
    its solution is that of the held partition, so the held central difference is the derivative of
    the discrete solution; the free re-solve instead jumps slightly each time a boundary volume
    switches, and its central differences do not converge as the step shrinks (0.1-1 % scatter
    under step halving on the production mesh). Moving cavitation boundaries add nothing at first
    order: the pressure vanishes on them, so the force gained or lost in a swept strip is second
    order (the held stiffness agrees with free re-solves at moderate steps and converges with the
    mesh; tests/test_bearing_coefficients.py). Velocity steps are ``step_ratio * c * Omega``.
    With ``squeeze="full-film"`` the velocity response is taken on the equilibrium partition with
    the film content frozen (see :mod:`oilwatch.models.bearing.film`); it is linear in the velocity and the
    central difference is exact. With ``squeeze="everywhere"`` the quasi-steady film is re-solved on
    the held partition (a free re-solve would scatter like the free stiffness).

    Any load direction (``Equilibrium.load_angle_rad``): the steps are along x and y about the
    equilibrium's own position and film, so K and C are the (x, y)-frame coefficients whichever way
    the load points; nothing here assumes -y.

    On the flooded threshold (groove just full at zero pressure, the table's q_t node) the force
    has a genuine kink in the journal position and velocity: starved on one side, flooded on the
    other, and K, C jump across q_t. There the mean of the two one-sided limits is returned
    (:func:`one_sided_coefficients`): the limit of symmetric central differences through the kink,
    i.e. the coefficient seen by a small orbit about that equilibrium, and the midpoint of the jump
    through which the table interpolates.
    """
    if on_flooded_threshold(equilibrium.film, supply, speed_hz):
        sides = one_sided_coefficients(
            bearing, equilibrium, speed_hz, supply, mesh, squeeze=squeeze, step_ratio=step_ratio
        )
        return tuple(0.5 * (sides["starved"][k] + sides["flooded"][k]) for k in range(2))
    return _branch_coefficients(
        bearing, equilibrium.eccentricity_m, equilibrium.film, speed_hz, supply, mesh, squeeze, step_ratio
    )


def _branch_coefficients(bearing, e0, base, speed_hz, supply, mesh, squeeze, step_ratio):
    """K and C by central differences on the partition of ``base`` (the film at ``e0``)."""
    dx = step_ratio * bearing.clearance_m
    dv = dx * 2.0 * math.pi * speed_hz
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
                hold_partition=True,
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
    load_angle_rad: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """K (2, 2) [N/m] and C (2, 2) [N s/m] at the static equilibrium (Lund's convention).

    ``load_angle_rad``: the bearing angle the load points along [rad], the bearing's own by default
    (:func:`static_equilibrium`); K and C stay in the (x, y) frame whatever the load direction.
    """
    eq = static_equilibrium(
        bearing, load_n, speed_hz, supply, mesh, squeeze=squeeze, load_angle_rad=load_angle_rad
    )
    return coefficients_at(bearing, eq, speed_hz, supply, mesh, squeeze=squeeze, step_ratio=step_ratio)
