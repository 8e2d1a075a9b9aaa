"""Transient mass-conserving p-theta film: one implicit time step of the Elrod-Adams / JFO model.

Method (Ausas, Jai & Buscaglia, J. Tribol. 131, 031702, 2009, in the complementarity form of
Giacopini et al., J. Tribol. 132, 041702, 2010): every control volume k of the steady solver's
finite-volume grid (:mod:`oilwatch.models.bearing.discretization`) balances its film content
``m_k = V_k(e) theta_k`` [m^3], with ``V_k(e) = integral(h dA) = A_k c + e_x wx_k + e_y wy_k`` the
volume of the gap over it (exact for the rigid journal, the same quadrature as the force and the
squeeze term), against the Poiseuille and Couette fluxes and the groove's supply flow q:

    d m_k / dt  +  sum_j Ap[k, j] p_j  +  sum_j At[k, j] theta_j  =  q delta_{k, groove}

with p_k >= 0, theta_k <= 1, p_k (1 - theta_k) = 0. The time derivative is implicit (backward Euler,
``order=1``, or the second-order BDF, ``order=2``): the fluid fraction is transported implicitly,
so the Couette Courant number is not limited. Each step is then the steady solver's mixed
complementarity problem with a diagonal ``beta V_k / dt`` added to the cavitated (theta) columns
and the old content on the right-hand side, solved by the same primal-dual active-set (semi-smooth
Newton) iteration, warm-started from the previous step's partition and unknowns.

Per step the discrete balance summed over all volumes is exact (the fluxes telescope):
supply - side leakage - d(film content)/dt = 0 to the linear solver's tolerance (tested).

Fast path: the step is solved by projected multigrid cycles
(:mod:`oilwatch.models.bearing.transient_multigrid`: the projected Gauss-Seidel sweep of Ausas et al. as
smoother, an aggregation coarse correction of the pressurized region) on large meshes, by projected SOR sweeps
(:mod:`oilwatch.models.bearing.transient_sweep`) on small ones, warm-started from the film extrapolated
linearly in time; a step is accepted only when every volume's residual and the step's mass balance meet the
tolerances, else the active set (:mod:`oilwatch.models.bearing.transient_active_set`, an LU-preconditioned
GMRES per iteration) finishes it (the fallback).

Symmetry: the journal is rigid and aligned and the groove axially centred, so the film is
mirror-symmetric about the mid-plane; on an even ``n_axial`` only the half z < L/2 is solved (closed
at the mid-plane, :func:`oilwatch.models.bearing.grid.film_grid` with ``half``) and forces, flows and content
are doubled (tested against the whole film). It halves every solver's cost.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..validation import InputError, require_non_negative, require_positive
from .discretization import force_weights
from .film import FilmSolution, validate_state
from .geometry import JournalBearing
from .grid import PRODUCTION_MESH, FilmGrid, Mesh, film_grid
from .transient_active_set import (
    ActiveSetStart,
    ActiveSetStep,
    extrapolated_start,
)
from .transient_kernels import StepArrays, StepAssembly, step_source, sweep_start
from .transient_multigrid import CoarseCorrection, multigrid_solve
from .transient_sweep import sor_sweeps

BDF = {1: (1.0, (-1.0,)), 2: (1.5, (-2.0, 0.5))}
"""Backward-differentiation weights: d m/dt ~ (beta m^{n+1} + sum_i a_i m^{n-i}) / dt."""
SWEEP_RELAXATION_SCALE = 1.78
"""Over-relaxation of the pressure: omega = 2 / (1 + SWEEP_RELAXATION_SCALE / n_axial), the mesh scaling
of the optimal SOR factor (2 / (1 + pi h / L)), fitted on 60 x 16 (3 um whirl, omega 1.8: 92 sweeps per
step; 1.5: 240; 1.9: 180) and checked on 120 x 36 (1.906: about 190 sweeps; 1.8: 324). The factor sets
how fast the sweeps converge, not what they converge to."""
SWEEP_LIMIT = 400
SWEEP_PREDICTOR = 24
SWEEP_MAX_NODES = 5000
"""SOR's sweeps grow with the mesh (elliptic pressure): on meshes above this many volumes (240 x 72:
16777) a converged sweep costs more than the active-set solve, so only ``SWEEP_PREDICTOR`` sweeps
run, to move the partition and the fill before the active set takes over."""
SWEEP_CHECK_EVERY = 4
SWEEP_RESIDUAL_TOLERANCE = 1e-11
"""A sweep-solved step is accepted when every volume's balance residual is below this times U c L / 2 ..."""
SWEEP_MASS_TOLERANCE = 1e-10
"""... and the step's mass-balance error (the residuals' sum) below this times the supply flow."""
SOLVERS = ("multigrid", "sweeps", "active-set")
"""``solver`` of :class:`TransientFilm`: projected multigrid cycles
(:mod:`oilwatch.models.bearing.transient_multigrid`) or projected SOR sweeps
(:mod:`oilwatch.models.bearing.transient_sweep`), each finished by the active set when it does not meet the
tolerances; or the active set alone. The default: multigrid above :data:`MULTIGRID_MIN_NODES` volumes."""
MULTIGRID_CYCLE_LIMIT = 100
"""Multigrid cycles tried before the active set finishes a step."""
MULTIGRID_MIN_NODES = 1000
"""The default solver is the multigrid on grids of more volumes than this, else the sweeps. One bearing,
3 um whirl at 64 steps per revolution, CPU per step under load ~17 (/tmp scans, residual 1e-8 / 1e-11):
60 x 16 half (469 volumes) sweeps 0.84 ms, multigrid 1.34 ms; 120 x 36 half (2098) sweeps 8.5 ms,
multigrid 4.4 ms (1e-11); 240 x 72 half (8389) multigrid 31 cycles, 16 ms (1e-11)."""


def default_sweep_limit(n_nodes: int) -> int:
    """Sweeps tried before the active set (see :data:`SWEEP_MAX_NODES`)."""
    return SWEEP_LIMIT if n_nodes <= SWEEP_MAX_NODES else SWEEP_PREDICTOR


@dataclass(frozen=True, eq=False)
class TransientFilmState:
    """The film of one bearing at one instant (node arrays, see
    :class:`oilwatch.models.bearing.grid.FilmGrid`).

    pressure_pa, fill_fraction (n_nodes,); full (n_nodes,) bool partition; content_m3 (n_nodes,)
    film content V theta; previous_content_m3 the content one step earlier (None before the first
    step: BDF2 starts with an Euler step); eccentricity_m (2,) journal position [m]; force_n (2,)
    film force on the journal [N]; side_leakage_m3_s, supply_flow_m3_s [m^3/s]; time_s [s];
    iterations active-set iterations of the last step, gmres_iterations its linear iterations.
    """

    pressure_pa: np.ndarray
    fill_fraction: np.ndarray
    full: np.ndarray
    content_m3: np.ndarray
    previous_content_m3: np.ndarray | None
    eccentricity_m: np.ndarray
    force_n: np.ndarray
    side_leakage_m3_s: float
    supply_flow_m3_s: float
    time_s: float
    iterations: int = 0
    gmres_iterations: int = 0
    sweeps: int = 0
    sweep_residual: float = 0.0
    previous_pressure_pa: np.ndarray | None = None
    previous_fill_fraction: np.ndarray | None = None
    mirror: float = 1.0

    @property
    def total_content_m3(self) -> float:
        """Oil held in the film [m^3] (``mirror`` = 2: the arrays hold the half z < L/2)."""
        return float(self.mirror * self.content_m3.sum())


class TransientFilm(ActiveSetStep):
    """Time stepper of one bearing's p-theta film at a fixed spin speed.

    Parameters: ``bearing``; ``speed_hz`` [Hz]; ``mesh`` (default the production mesh); ``order``
    1 (backward Euler) or 2 (BDF2); ``residual_tolerance`` and ``mass_tolerance`` the acceptance of a
    sweep-solved step (see :data:`SWEEP_RESIDUAL_TOLERANCE`); ``sweep_limit`` the projected SOR sweeps
    tried before the active-set solve (default :func:`default_sweep_limit`; 0: active set only).

    ``sweep_count`` and ``fallbacks`` count the sweeps done and the steps the active set had to finish.
    """

    def __init__(
        self,
        bearing: JournalBearing,
        speed_hz: float,
        mesh: Mesh | None = None,
        order: int = 2,
        *,
        residual_tolerance: float = SWEEP_RESIDUAL_TOLERANCE,
        mass_tolerance: float = SWEEP_MASS_TOLERANCE,
        sweep_limit: int | None = None,
        solver: str | None = None,
        symmetric: bool | None = None,
    ):
        if order not in BDF:
            raise InputError(f"order must be 1 or 2 (backward Euler or BDF2), got {order!r}")
        self.bearing = bearing
        self.speed_hz = require_positive("speed_hz", speed_hz, "Hz")
        self.omega_rad_s = 2.0 * math.pi * self.speed_hz
        self.mesh = PRODUCTION_MESH if mesh is None else mesh
        self.full_grid: FilmGrid = film_grid(bearing, self.mesh)
        self.symmetric = self.mesh.n_axial % 2 == 0 if symmetric is None else bool(symmetric)
        self.grid: FilmGrid = film_grid(bearing, self.mesh, half=True) if self.symmetric else self.full_grid
        self.mirror = 2.0 if self.symmetric else 1.0
        self.order = order
        grid = self.grid
        self.wx, self.wy = force_weights(grid)
        area = (bearing.radius_m * grid.dpsi)[:, None] * grid.dz[None, :]
        self.area_m2 = np.bincount(grid.node_of_cell.ravel(), weights=area.ravel(), minlength=grid.n_nodes)
        self._gap_m3 = self.area_m2 * bearing.clearance_m
        self.p_ref = bearing.viscosity_pa_s * self.omega_rad_s * bearing.radius_m**2 / bearing.clearance_m**2
        self._assembly = StepAssembly(grid, bearing.viscosity_pa_s, self.omega_rad_s, self.p_ref)
        self.couette_scale_m3_s = (
            0.5 * self.omega_rad_s * bearing.radius_m * bearing.clearance_m * bearing.length_m
        )
        """The whole bearing's Couette flow U c L / 2 [m^3/s]: the residuals' scale."""
        self._lu = None
        self.factorizations = 0
        self.relaxation = 2.0 / (1.0 + SWEEP_RELAXATION_SCALE / self.mesh.n_axial)
        if solver is None:
            large = grid.n_nodes > MULTIGRID_MIN_NODES
            solver = "active-set" if sweep_limit == 0 else "multigrid" if large else "sweeps"
        if solver not in SOLVERS:
            raise InputError(f"solver must be one of {', '.join(SOLVERS)}; got {solver!r}")
        self.solver = solver
        if solver == "multigrid":
            default_limit = MULTIGRID_CYCLE_LIMIT
        else:
            default_limit = 0 if solver == "active-set" else default_sweep_limit(grid.n_nodes)
        self.sweep_limit = default_limit if sweep_limit is None else int(sweep_limit)
        if self.sweep_limit < 0:
            raise InputError(f"sweep_limit must be >= 0, got {sweep_limit!r}")
        self._coarse = CoarseCorrection(grid) if solver == "multigrid" else None
        self.residual_tolerance = require_positive("residual_tolerance", residual_tolerance)
        self.mass_tolerance = require_positive("mass_tolerance", mass_tolerance)
        self.sweep_count = 0
        self.fallbacks = 0

    def gap_volume_m3(self, eccentricity_m) -> np.ndarray:
        """V_k = integral(h dA) over every control volume [m^3] for the journal at ``eccentricity_m``."""
        ex, ey = eccentricity_m
        return self._gap_m3 + ex * self.wx + ey * self.wy

    def from_steady(self, film: FilmSolution, eccentricity_m, time_s: float = 0.0) -> TransientFilmState:
        """The transient state of a steady film solution (same bearing, speed and mesh)."""
        if film.grid is not self.full_grid:
            raise InputError("the steady film must be on the transient film's mesh and bearing")
        n = self.grid.n_nodes
        p = np.zeros(n)
        theta = np.zeros(n)
        cells = self.grid.node_of_cell
        p[cells] = film.pressure_pa[:, : cells.shape[1]]
        theta[cells] = film.fill_fraction[:, : cells.shape[1]]
        e = np.asarray(eccentricity_m, dtype=float)
        content = theta * self.gap_volume_m3(e)
        return TransientFilmState(
            p,
            theta,
            theta >= 1.0,
            content,
            None,
            e.copy(),
            np.array(film.force_n),
            film.side_leakage_m3_s,
            film.supply_flow_m3_s,
            float(time_s),
            mirror=self.mirror,
        )

    def cell_values(self, node_values: np.ndarray) -> np.ndarray:
        """A node array of this film's states as (n_circ, n_axial) cells of the whole bearing (the
        symmetric half mirrored)."""
        half = np.asarray(node_values)[self.grid.node_of_cell]
        return np.concatenate([half, half[:, ::-1]], axis=1) if self.symmetric else half

    def step(
        self,
        state: TransientFilmState,
        eccentricity_m,
        supply_flow_m3_s: float,
        dt_s: float,
        max_iterations: int = 60,
        guess: TransientFilmState | None = None,
    ) -> TransientFilmState:
        """Advance ``state`` by ``dt_s`` [s] to the journal position ``eccentricity_m`` [m] (at the new
        time) with the supply flowrate ``supply_flow_m3_s`` [m^3/s] into the groove over the step.

        ``guess``: a state whose partition and unknowns start the iteration (default ``state``), e.g.
        the previous iterate of an implicit rotor-film coupling. The step is solved by projected SOR
        sweeps (:mod:`oilwatch.models.bearing.transient_sweep`) when they meet the tolerances within
        ``sweep_limit`` sweeps; otherwise the active-set solve finishes it from the sweeps' result.
        ``sweeps`` and ``sweep_residual`` of the result say how many were done and what they reached."""
        dt = require_positive("dt_s", dt_s, "s")
        q = require_non_negative("supply_flow_m3_s", supply_flow_m3_s, "m^3/s")
        e = np.asarray(eccentricity_m, dtype=float)
        _, ex, ey, _ = validate_state(self.bearing, self.speed_hz, (e[0], e[1]), (0.0, 0.0), "full-film")
        arrays = self._assembly.fill(ex, ey)
        order = self.order if state.previous_content_m3 is not None else 1
        beta, history = BDF[order]
        previous = state.previous_content_m3 if order == 2 else state.content_m3
        weights = (history[0], history[1] if order == 2 else 0.0)
        volume = np.empty(self.grid.n_nodes)
        step_source(
            self._gap_m3, self.wx, self.wy, ex, ey, beta / dt, 1.0 / dt, weights, state.content_m3, previous,
            arrays, volume,
        )  # fmt: skip
        arrays.rhs[self.grid.groove_node] += q / self.mirror
        sweep = self._sweeps(arrays, state, guess, q / self.mirror) if self.sweep_limit > 0 else None
        if sweep is not None and sweep[3]:
            p, theta, full = sweep[0], sweep[1], sweep[2]
            iteration, linear = 0, 0
        else:
            if sweep is not None:
                self.fallbacks += 1
                start = ActiveSetStart(sweep[0], sweep[1], sweep[2])
            else:
                start = extrapolated_start(state) if guess is None else guess
            p, theta, full, iteration, linear = self._active_set(arrays, start, max_iterations)
        # Volumes within the tolerance of a switch keep their (unclipped) solution: the balance stays exact.
        content = theta * volume
        return TransientFilmState(
            pressure_pa=p,
            fill_fraction=theta,
            full=full,
            content_m3=content,
            previous_content_m3=state.content_m3,
            eccentricity_m=e.copy(),
            force_n=self.mirror * np.array([p @ self.wx, p @ self.wy]),
            side_leakage_m3_s=self.mirror * self._assembly.side_leakage(p) / self.p_ref,
            supply_flow_m3_s=q,
            time_s=state.time_s + dt,
            iterations=iteration,
            gmres_iterations=linear,
            sweeps=0 if sweep is None else sweep[4],
            sweep_residual=0.0 if sweep is None else sweep[5],
            previous_pressure_pa=state.pressure_pa,
            previous_fill_fraction=state.fill_fraction,
            mirror=self.mirror,
        )

    def _sweeps(self, arrays: StepArrays, state: TransientFilmState, guess, q: float):
        """Projected SOR or multigrid (:mod:`oilwatch.models.bearing.transient_sweep`) from ``guess``, else
        from ``state`` extrapolated in time (as
        :func:`~oilwatch.models.bearing.transient_active_set.extrapolated_start`, compiled: ``sweep_start``):
        (p [Pa], theta, full, converged, sweeps, max |residual| / (U c L / 2))."""
        n = self.grid.n_nodes
        p, theta = np.empty(n), np.empty(n)
        start = state if guess is None else guess
        extrapolate = guess is None and state.previous_pressure_pa is not None
        sweep_start(
            start.pressure_pa,
            start.fill_fraction,
            start.full,
            state.previous_pressure_pa if extrapolate else start.pressure_pa,
            state.previous_fill_fraction if extrapolate else start.fill_fraction,
            extrapolate,
            self.p_ref,
            p,
            theta,
        )
        scale = self.couette_scale_m3_s / self.mirror  # the grid's own Couette flow (half the bearing's)
        limits = (self.residual_tolerance * scale, self.mass_tolerance * max(q, scale * 1e-3))
        if self._coarse is not None:
            sweeps, worst, _, converged = multigrid_solve(
                self._coarse, arrays, p, theta, *limits, self.sweep_limit
            )
        else:
            sweeps, worst, _, converged = sor_sweeps(
                arrays, p, theta, self.relaxation, *limits, self.sweep_limit, SWEEP_CHECK_EVERY
            )
        self.sweep_count += sweeps
        full = theta >= 1.0
        return p * self.p_ref, theta, full, converged, sweeps, worst / scale


def mass_balance_error(film: TransientFilm, before: TransientFilmState, after: TransientFilmState) -> float:
    """supply - side leakage - d(content)/dt of a step, relative to the supply flow [-]."""
    dt = after.time_s - before.time_s
    if before.previous_content_m3 is not None and film.order == 2:
        rate = (
            1.5 * after.content_m3 - 2.0 * before.content_m3 + 0.5 * before.previous_content_m3
        ).sum() / dt
    else:
        rate = (after.content_m3 - before.content_m3).sum() / dt
    rate *= film.mirror
    return float((after.supply_flow_m3_s - after.side_leakage_m3_s - rate) / after.supply_flow_m3_s)
