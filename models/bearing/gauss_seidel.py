"""Reference p-theta solver: plain Gauss-Seidel on the same discretization (Ausas et al. 2009).

Each volume in turn is first assumed full (theta = 1) and its pressure solved from its own balance;
if that pressure is negative the volume is cavitated (p = 0) and its fill solved instead. This is
the classical Elrod-Adams / Ausas relaxation (no over-relaxation), compiled with numba. It shares
:func:`oilwatch.models.bearing.discretization.film_operator` with the fast solver, so both converge to the
same discrete solution; it exists to check :func:`oilwatch.models.bearing.film.solve_film` and to measure
how much faster that is (``benchmarks/bearing_solve.py``). Steady films only (no journal velocity).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..validation import InputError, require_positive
from .discretization import film_operator
from .film import FilmSolution, _finish, validate_state
from .geometry import JournalBearing
from .grid import PRODUCTION_MESH, Mesh, film_grid
from .supply import Supply, SupplyFlow, SupplyPressure


@njit(cache=True)
def _gauss_seidel(indptr, indices, ap, at, src, p, theta, fixed_node, flow_scale, tol, max_sweeps):
    """Sweep until the largest balance correction of a sweep is below tol * flow_scale [m^3/s].

    Returns the number of sweeps, or -1 when max_sweeps is reached. p, theta are updated in place.
    """
    n = p.size
    for sweep in range(max_sweeps):
        worst = 0.0
        for i in range(n):
            if i == fixed_node:
                continue
            off_p = 0.0
            off_t = 0.0
            dp = 1.0
            dt = 1.0
            for k in range(indptr[i], indptr[i + 1]):
                j = indices[k]
                if j == i:
                    dp = ap[k]
                    dt = at[k]
                else:
                    off_p += ap[k] * p[j]
                    off_t += at[k] * theta[j]
            rhs = src[i] - off_p - off_t
            p_new = (rhs - dt) / dp
            if p_new > 0.0:
                t_new = 1.0
            else:
                p_new = 0.0
                t_new = min(max(rhs / dt, 0.0), 1.0)
            change = abs(dp * (p_new - p[i])) + abs(dt * (t_new - theta[i]))
            if change > worst:
                worst = change
            p[i] = p_new
            theta[i] = t_new
        if worst < tol * flow_scale:
            return sweep + 1
    return -1


def gauss_seidel_film(
    bearing: JournalBearing,
    speed_hz: float,
    eccentricity_m: tuple[float, float],
    supply: Supply,
    mesh: Mesh | None = None,
    *,
    tolerance: float = 1e-11,
    max_sweeps: int = 2_000_000,
) -> FilmSolution:
    """Steady p-theta film by plain Gauss-Seidel (same inputs and output as ``solve_film``).

    ``tolerance``: stop when no volume's balance changes by more than tolerance * U c L / 2 in a
    sweep. ``iterations`` of the result counts sweeps.
    """
    mesh = PRODUCTION_MESH if mesh is None else mesh
    if not isinstance(supply, SupplyFlow | SupplyPressure):
        raise InputError(f"supply must be SupplyFlow or SupplyPressure, got {supply!r}")
    require_positive("tolerance", tolerance)
    omega, ex, ey, _ = validate_state(bearing, speed_hz, eccentricity_m, (0.0, 0.0), "full-film")
    grid = film_grid(bearing, mesh)
    op = film_operator(grid, (ex, ey), (0.0, 0.0), omega)
    n = grid.n_nodes
    g = grid.groove_node
    src = np.zeros(n)
    p = np.zeros(n)
    theta = np.ones(n)
    fixed_node = -1
    if isinstance(supply, SupplyPressure):
        fixed_node = g
        p[g] = supply.p_pa
    else:
        src[g] = supply.q_m3_s
    sweeps = _gauss_seidel(
        grid.pattern.indptr.astype(np.int64),
        grid.pattern.indices.astype(np.int64),
        op.ap_data,
        op.at_data,
        src,
        p,
        theta,
        fixed_node,
        op.couette_scale_m3_s,
        tolerance,
        max_sweeps,
    )
    if sweeps < 0:
        raise RuntimeError(f"Gauss-Seidel did not converge in {max_sweeps} sweeps")
    full = theta >= 1.0
    full[g] = full[g] or p[g] > 0.0
    return _finish(op, supply, full, p, theta, sweeps, np.zeros(n))
