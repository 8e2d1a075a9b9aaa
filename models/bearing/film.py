"""Mass-conserving p-theta film solver: complementarity form solved by a semi-smooth Newton method.

The discrete problem (see :mod:`oilwatch.models.bearing.discretization`) is a mixed linear complementarity
problem (Giacopini et al., J. Tribol. 132, 041702, 2010): for every control volume k

    Ap p + At theta + squeeze = source,    p_k >= 0,  1 - theta_k >= 0,  p_k (1 - theta_k) = 0.

It is solved by the semi-smooth Newton method on min(p_k, c (1 - theta_k)) = 0, i.e. a primal-dual
active-set iteration: each volume is either full (theta = 1, p unknown) or cavitated (p = 0,
theta unknown); one sparse direct solve per iteration gives all unknowns, then volumes whose
pressure came out negative cavitate and cavitated volumes that came out over-full are pressurized.
The iteration ends when the partition no longer changes, i.e. at the exact discrete solution (up
to round-off): typically 3-10 sparse solves from a cold start, 1-3 from a neighbouring solution.

Squeeze term under a journal velocity (the choice behind the damping coefficients)
----------------------------------------------------------------------------------
The damping is the force response to a journal velocity at frozen position. In a full volume
d(h theta)/dt = dh/dt. In a cavitated volume the oil rides in striations on the surfaces; at the
instant the velocity is applied the film content h*theta is the steady one and only transport
changes it later, so d(h theta)/dt = 0 there (theta adjusts to the moving wall, h theta does not).

``squeeze="full-film"`` (default) solves exactly that instantaneous problem: the steady film at
the given position is solved first; then its cavitated volumes keep their content and zero
pressure, while its full volumes take dh/dt and either stay pressurized or rupture (p = 0 with a
growing cavity): an LCP with an M-matrix, same active-set method. A cavitated volume cannot refill
instantly. ``hold_partition=True`` keeps every full volume pressurized: the response is then
linear in the velocity, which is the small-velocity limit used for the damping coefficients (and
makes C symmetric, as C = W^T A^-1 W with the symmetric Poiseuille operator A). Without a velocity,
``hold_partition=True`` re-solves a displaced journal on the reference partition: the smooth branch
of the discrete solution whose derivative is the stiffness.

``squeeze="everywhere"`` applies theta dh/dt in every volume and re-solves the quasi-steady film
(fills and cavitation boundaries re-adjust at once, as if the squeeze had lasted for ever). In the
cavitated zone the wall motion then acts as a volume source or sink, which moves the reformation
boundary: at nominal flow Cxy grows about 3-fold and Cyx shrinks about 8-fold (REFERENCE.md
warns of this). It is kept to show that effect, not for use.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..validation import InputError, require_finite, require_positive
from .discretization import FilmOperator, film_operator
from .geometry import JournalBearing
from .grid import (
    MIN_AXIAL_CELLS,
    MIN_CIRCUMFERENTIAL_CELLS,
    PRODUCTION_MESH,
    FilmGrid,
    Mesh,
    film_grid,
)
from .sparse_system import fix_groove_pressure, sparse_solve
from .supply import Supply, SupplyFlow, SupplyPressure

SQUEEZE_MODES = ("full-film", "everywhere")
MAX_ECCENTRICITY_RATIO = 0.98


@dataclass(frozen=True, eq=False)
class FilmSolution:
    """Converged film state.

    Attributes
    ----------
    pressure_pa : (n_circ, n_axial) gauge pressure [Pa], cell i at psi from the groove's upstream
        edge (see :mod:`oilwatch.models.bearing.grid`), groove cells at the groove pressure.
    fill_fraction : (n_circ, n_axial) theta [-].
    force_n : (2,) film force on the journal (F_x, F_y) [N].
    side_leakage_m3_s : flow out of both bearing ends [m^3/s].
    supply_flow_m3_s : flow into the groove [m^3/s] (given, or drawn at a given pressure).
    supply_pressure_pa : groove pressure [Pa].
    groove_fill_fraction : theta of the groove [-] (< 1 when starved).
    regime : "starved" (groove partly filled) or "flooded".
    iterations : sparse solves on this mesh (coarser meshes that seeded the partition excluded).
    residual : largest volume-balance error relative to the Couette flow U c L / 2 [-].
    """

    pressure_pa: np.ndarray
    fill_fraction: np.ndarray
    force_n: np.ndarray
    side_leakage_m3_s: float
    supply_flow_m3_s: float
    supply_pressure_pa: float
    groove_fill_fraction: float
    regime: str
    iterations: int
    residual: float
    grid: FilmGrid = field(repr=False)
    full: np.ndarray = field(repr=False)


def validate_state(
    bearing: JournalBearing,
    speed_hz: float,
    eccentricity_m: tuple[float, float],
    velocity_m_s: tuple[float, float],
    squeeze: str,
) -> tuple[float, float, float, float]:
    """Check the film-state inputs; return (omega [rad/s], ex [m], ey [m], eccentricity ratio)."""
    if not isinstance(bearing, JournalBearing):
        raise InputError(f"bearing must be a JournalBearing, got {type(bearing).__name__}")
    speed = require_positive("speed_hz", speed_hz, "Hz")
    ex = require_finite("eccentricity_m[0]", eccentricity_m[0])
    ey = require_finite("eccentricity_m[1]", eccentricity_m[1])
    ratio = math.hypot(ex, ey) / bearing.clearance_m
    if ratio >= MAX_ECCENTRICITY_RATIO:
        raise InputError(
            f"eccentricity_m gives an eccentricity ratio {ratio:.4g}; it must be < "
            f"{MAX_ECCENTRICITY_RATIO} (the journal would touch the bearing at 1)"
        )
    require_finite("velocity_m_s[0]", velocity_m_s[0])
    require_finite("velocity_m_s[1]", velocity_m_s[1])
    if squeeze not in SQUEEZE_MODES:
        raise InputError(f"squeeze must be one of {SQUEEZE_MODES}, got {squeeze!r}")
    return 2.0 * math.pi * speed, ex, ey, ratio


def initial_partition(op: FilmOperator, ex: float, ey: float) -> np.ndarray:
    """Half-Sommerfeld guess: volumes in the converging film full, the rest cavitated."""
    grid = op.grid
    alpha = grid.alpha_centres_rad[:, None] * np.ones(grid.mesh.n_axial)[None, :]
    converging = (ex * np.sin(alpha) - ey * np.cos(alpha)) < 0.0
    full = np.zeros(grid.n_nodes, dtype=bool)
    land = ~grid.in_groove
    full[grid.node_of_cell[land]] = converging[land]
    full[grid.groove_node] = True
    return full


def node_balance(op: FilmOperator, p: np.ndarray, theta: np.ndarray, squeeze_m3_s: np.ndarray) -> np.ndarray:
    """Net outflow plus applied squeeze of every volume [m^3/s] (the left side of discrete Eq. 1)."""
    slots = op.grid.slots
    rows, cols = slots["rows"], slots["columns"]
    n = op.grid.n_nodes
    flux = np.bincount(rows, weights=op.ap_data * p[cols] + op.at_data * theta[cols], minlength=n)
    return flux + squeeze_m3_s


def side_leakage(op: FilmOperator, p: np.ndarray) -> float:
    """Flow out of both bearing ends [m^3/s] (Poiseuille from the end volumes to ambient)."""
    return float(np.sum(op.end_conductance * p[op.end_nodes]))


def solve_film(
    bearing: JournalBearing,
    speed_hz: float,
    eccentricity_m: tuple[float, float],
    supply: Supply,
    velocity_m_s: tuple[float, float] = (0.0, 0.0),
    mesh: Mesh | None = None,
    *,
    squeeze: str = "full-film",
    warm_start: FilmSolution | None = None,
    hold_partition: bool = False,
    max_iterations: int = 100,
) -> FilmSolution:
    """Solve the p-theta film for a journal at ``eccentricity_m`` [m] moving at ``velocity_m_s`` [m/s].

    ``speed_hz`` is the shaft speed [Hz]; ``supply`` a :class:`SupplyFlow` or
    :class:`SupplyPressure`; ``mesh`` the finite-volume mesh (default ``PRODUCTION_MESH``);
    ``warm_start`` a neighbouring solution on the same mesh whose full/cavitated partition starts
    the iteration.
    ``hold_partition``: keep the partition of the reference film ``warm_start`` (groove state
    included) instead of settling a new one: one sparse solve on that partition, pressures and
    fills not clipped, i.e. the smooth branch of the discrete solution through ``warm_start``,
    whose derivative is the stiffness (see :mod:`oilwatch.models.bearing.equilibrium`). Required without a
    velocity. With a velocity and ``squeeze="full-film"`` every steady-full volume also stays
    pressurized, so the response is linear in the velocity: the small-velocity limit used for the
    damping; with ``squeeze="everywhere"`` the quasi-steady film is solved on that partition.
    """
    mesh = PRODUCTION_MESH if mesh is None else mesh
    if not isinstance(mesh, Mesh):
        raise InputError(f"mesh must be a Mesh, got {type(mesh).__name__}")
    if not isinstance(supply, SupplyFlow | SupplyPressure):
        raise InputError(f"supply must be SupplyFlow or SupplyPressure, got {supply!r}")
    omega, ex, ey, _ = validate_state(bearing, speed_hz, eccentricity_m, velocity_m_s, squeeze)
    grid = film_grid(bearing, mesh)
    op = film_operator(grid, (ex, ey), (float(velocity_m_s[0]), float(velocity_m_s[1])), omega)
    moving = bool(np.any(op.squeeze_m3_s != 0.0))
    if hold_partition and not moving:
        if warm_start is None or warm_start.grid is not grid:
            raise InputError("hold_partition without a velocity needs a warm_start on the same mesh")
        zero = np.zeros(grid.n_nodes)
        full, p, theta = _held_partition_solve(op, supply, warm_start.full, zero)
        return _finish(op, supply, full, p, theta, 1, zero)
    if squeeze == "everywhere" and moving:
        if hold_partition and warm_start is not None and warm_start.grid is grid:
            full, p, theta = _held_partition_solve(op, supply, warm_start.full, op.squeeze_m3_s, True)
            return _finish(op, supply, full, p, theta, 1, theta * op.squeeze_m3_s)
        full, p, theta, iterations = _active_set_newton(
            op, supply, ex, ey, op.squeeze_m3_s, True, warm_start, max_iterations
        )
        return _finish(op, supply, full, p, theta, iterations, theta * op.squeeze_m3_s)
    zero = np.zeros(grid.n_nodes)
    if hold_partition and warm_start is not None and warm_start.grid is grid:
        full, p, theta = _held_partition_solve(op, supply, warm_start.full, zero)
        iterations = 1
    else:
        full, p, theta, iterations = _active_set_newton(
            op, supply, ex, ey, zero, False, warm_start, max_iterations
        )
    if not moving:
        return _finish(op, supply, full, p, theta, iterations, zero)
    active, p, more = _frozen_content_response(op, supply, full, theta, max_iterations, hold_partition)
    return _finish(op, supply, active, p, theta, iterations + more, op.squeeze_m3_s * full, active)


def _reference_pressure(op: FilmOperator) -> float:
    """mu U R / c^2 [Pa]: the hydrodynamic pressure scale used to scale the unknowns."""
    bearing = op.grid.bearing
    return bearing.viscosity_pa_s * op.omega_rad_s * bearing.radius_m**2 / bearing.clearance_m**2


def _active_set_newton(op, supply, ex, ey, squeeze_m3_s, everywhere, warm_start, max_iterations):
    """Steady (or quasi-steady) p-theta partition, pressures and fills on one mesh."""
    grid = op.grid
    slots = grid.slots
    rows, cols, diag = slots["rows"], slots["columns"], slots["diag"]
    n = grid.n_nodes
    g = grid.groove_node
    p_ref = _reference_pressure(op)
    fixed = isinstance(supply, SupplyPressure)
    source = np.zeros(n)
    if not fixed:
        source[g] = supply.q_m3_s
    if warm_start is not None and warm_start.grid is grid:
        full = warm_start.full.copy()
    else:
        full = _coarse_partition(op, supply, ex, ey, everywhere, max_iterations)
    if fixed:
        full[g] = True
    ap_scaled = op.ap_data * p_ref
    tol_p = 1e-12 * p_ref
    seen: set[bytes] = set()
    for iteration in range(1, max_iterations + 1):
        cav = ~full
        data = np.where(full[cols], ap_scaled, op.at_data)
        if everywhere:
            data[diag] += squeeze_m3_s * cav
        rhs = source - np.bincount(rows, weights=op.at_data * full[cols], minlength=n)
        rhs -= squeeze_m3_s * full
        if fixed:
            fix_groove_pressure(grid, data, rhs, supply.p_pa / p_ref)
        u = sparse_solve(grid, data, rhs)
        p = np.where(full, u * p_ref, 0.0)
        theta = np.where(full, 1.0, u)
        new_full = full.copy()
        new_full[full & (p < -tol_p)] = False
        new_full[cav & (theta > 1.0 + 1e-12)] = True
        if fixed:
            new_full[g] = True
        if np.array_equal(new_full, full):
            return full, np.maximum(p, 0.0), np.clip(theta, 0.0, 1.0), iteration
        key = np.packbits(new_full).tobytes()
        if key in seen:
            # A cycle of partitions: switch only the worst volume, which always makes progress.
            new_full = full.copy()
            worst_p = np.where(full, p, np.inf).argmin()
            worst_t = np.where(cav, theta, -np.inf).argmax()
            if -p[worst_p] / p_ref >= theta[worst_t] - 1.0:
                new_full[worst_p] = False
            else:
                new_full[worst_t] = True
        seen.add(key)
        full = new_full
    raise RuntimeError(
        f"p-theta active-set iteration did not converge in {max_iterations} sparse solves "
        f"(mesh {grid.mesh.n_circ} x {grid.mesh.n_axial})"
    )


def _held_partition_solve(op, supply, full, squeeze_m3_s, everywhere=False):
    """One sparse solve of the steady balance on a given partition; (full, p, theta) unclipped.

    ``everywhere``: the squeeze acts as theta dh/dt in cavitated volumes too (``squeeze="everywhere"``).

    Cells of the partition that would switch in a free solve show up as p < 0 or theta > 1: the
    result is the analytic continuation of the smooth solution branch on that partition.
    """
    grid = op.grid
    slots = grid.slots
    rows, cols = slots["rows"], slots["columns"]
    n = grid.n_nodes
    p_ref = _reference_pressure(op)
    fixed = isinstance(supply, SupplyPressure)
    full = full.copy()
    if fixed:
        full[grid.groove_node] = True
    source = np.zeros(n)
    if not fixed:
        source[grid.groove_node] = supply.q_m3_s
    data = np.where(full[cols], op.ap_data * p_ref, op.at_data)
    if everywhere:
        data[slots["diag"]] += squeeze_m3_s * ~full
    rhs = source - np.bincount(rows, weights=op.at_data * full[cols], minlength=n) - squeeze_m3_s * full
    if fixed:
        fix_groove_pressure(grid, data, rhs, supply.p_pa / p_ref)
    u = sparse_solve(grid, data, rhs)
    return full, np.where(full, u * p_ref, 0.0), np.where(full, 1.0, u)


def _frozen_content_response(op, supply, full0, theta0, max_iterations, hold_partition):
    """Pressure of a moving journal with the film content frozen (``squeeze="full-film"``).

    Cavitated volumes keep their steady fill theta0 and zero pressure; volumes full in the steady
    state take the squeeze dh/dt and either stay pressurized (p > 0) or rupture (p = 0 with a
    growing cavity, rate R >= 0): an LCP in p with an M-matrix, solved by the same active-set
    iteration (monotone convergence); ``hold_partition`` skips the rupture check (linear
    response). Returns (active set, p, sparse solves).
    """
    grid = op.grid
    slots = grid.slots
    rows, cols, diag = slots["rows"], slots["columns"], slots["diag"]
    n = grid.n_nodes
    g = grid.groove_node
    p_ref = _reference_pressure(op)
    fixed = isinstance(supply, SupplyPressure)
    source = np.zeros(n)
    if not fixed:
        source[g] = supply.q_m3_s
    frozen = source - np.bincount(rows, weights=op.at_data * theta0[cols], minlength=n)
    frozen -= op.squeeze_m3_s * full0
    ap_scaled = op.ap_data * p_ref
    active = full0.copy()
    for iteration in range(1, max_iterations + 1):
        data = np.where(active[rows] & active[cols], ap_scaled, 0.0)
        data[diag[~active]] = 1.0
        rhs = np.where(active, frozen, 0.0)
        if fixed:
            fix_groove_pressure(grid, data, rhs, supply.p_pa / p_ref)
        p = np.where(active, sparse_solve(grid, data, rhs) * p_ref, 0.0)
        rate = np.bincount(rows, weights=op.ap_data * p[cols], minlength=n) - frozen
        new_active = active.copy()
        new_active[active & (p < -1e-12 * p_ref)] = False
        new_active[full0 & ~active & (rate < 0.0)] = True
        if fixed:
            new_active[g] = True
        if hold_partition:
            return active, p, iteration
        if np.array_equal(new_active, active):
            return active, np.maximum(p, 0.0), iteration
        active = new_active
    raise RuntimeError(f"squeeze response did not converge in {max_iterations} sparse solves")


def _coarse_partition(op, supply, ex, ey, everywhere, max_iterations) -> np.ndarray:
    """Starting partition from the solution on a mesh half as fine (recursively), else a guess.

    The coarse solve costs a fraction of a fine iteration and leaves only the cells near the
    cavitation boundaries to be settled on the fine mesh.
    """
    grid = op.grid
    mesh = grid.mesh
    n_c, n_a = mesh.n_circ // 2, mesh.n_axial // 2
    if n_c < 2 * MIN_CIRCUMFERENTIAL_CELLS or n_a < MIN_AXIAL_CELLS:
        return initial_partition(op, ex, ey)
    coarse_grid = film_grid(grid.bearing, Mesh(n_c, n_a))
    coarse_op = film_operator(coarse_grid, (ex, ey), op.velocity_m_s, op.omega_rad_s)
    squeeze = coarse_op.squeeze_m3_s if everywhere else np.zeros(coarse_grid.n_nodes)
    full_c, _, _, _ = _active_set_newton(coarse_op, supply, ex, ey, squeeze, everywhere, None, max_iterations)
    psi_c = 0.5 * (grid.psi_faces_rad[:-1] + grid.psi_faces_rad[1:])
    z_c = 0.5 * (grid.z_faces_m[:-1] + grid.z_faces_m[1:])
    ic = np.clip(np.searchsorted(coarse_grid.psi_faces_rad, psi_c) - 1, 0, n_c - 1)
    jc = np.clip(np.searchsorted(coarse_grid.z_faces_m, z_c) - 1, 0, n_a - 1)
    state = full_c[coarse_grid.node_of_cell[np.ix_(ic, jc)]]
    full = np.zeros(grid.n_nodes, dtype=bool)
    full[grid.node_of_cell] = state
    full[grid.groove_node] = full_c[coarse_grid.groove_node]
    return full


def _finish(op, supply, full, p, theta, iterations, squeeze_m3_s, balanced=None) -> FilmSolution:
    """Package a solution; ``balanced`` masks the volumes whose balance holds (default all)."""
    grid = op.grid
    g = grid.groove_node
    balance = node_balance(op, p, theta, squeeze_m3_s)
    if isinstance(supply, SupplyPressure):
        q = float(balance[g])
        balance[g] = 0.0
    else:
        q = supply.q_m3_s
        balance[g] -= q
    if balanced is not None:
        balance = balance[balanced]
    residual = float(np.abs(balance).max() / op.couette_scale_m3_s)
    cells = grid.node_of_cell
    return FilmSolution(
        pressure_pa=p[cells],
        fill_fraction=theta[cells],
        force_n=np.array([p @ op.wx, p @ op.wy]),
        side_leakage_m3_s=side_leakage(op, p),
        supply_flow_m3_s=q,
        supply_pressure_pa=float(p[g]),
        groove_fill_fraction=float(theta[g]),
        regime="flooded" if full[g] or theta[g] >= 1.0 - 1e-9 else "starved",
        iterations=iterations,
        residual=residual,
        grid=grid,
        full=full,
    )
