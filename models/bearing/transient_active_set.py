"""The active-set solve of one transient film step: the fallback that finishes what the sweeps did not.

The step of :class:`oilwatch.models.bearing.transient.TransientFilm` is a mixed complementarity problem (p >=
0, theta <= 1, p (1 - theta) = 0), solved as the steady solver's by the primal-dual active-set (semi-smooth
Newton) iteration: each iteration solves the linear balance of the current full/cavitated partition and
switches the volumes whose pressure went negative or whose fill fraction exceeded 1 (Ausas, Jai &
Buscaglia, J. Tribol. 131, 031702, 2009; Giacopini et al., J. Tribol. 132, 041702, 2010). When a partition
comes back, only the worst volume switches, to break the cycle.

Linear solves: the step matrices of successive steps differ little (the journal moves a fraction
of the clearance, a few volumes switch), so the sparse LU of one step is reused as the
preconditioner of GMRES for the next ones and refactored only when GMRES needs more than
``REFACTOR_ITERATIONS`` iterations. The LU itself costs ~20 triangular solves.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, gmres, splu

from .transient_kernels import StepArrays

if TYPE_CHECKING:
    from .transient import TransientFilmState

REFACTOR_ITERATIONS = 12
LINEAR_TOLERANCE = 1e-11
"""GMRES stops when the volume-balance residual (2-norm) is below this times the Couette flow U c L / 2."""


class ActiveSetStart(NamedTuple):
    """Unknowns and partition that start the active-set iteration."""

    pressure_pa: np.ndarray
    fill_fraction: np.ndarray
    full: np.ndarray


class ActiveSetStep:
    """The active-set solve of :class:`~oilwatch.models.bearing.transient.TransientFilm` (a mixin: it uses the
    film's ``grid``, ``p_ref`` and ``couette_scale_m3_s``, and keeps the reused LU in ``_lu`` and its count in
    ``factorizations``)."""

    def _active_set(self, arrays: StepArrays, start, max_iterations: int):
        """The primal-dual active-set solve of the step's complementarity problem from ``start``."""
        grid = self.grid
        rows, cols, diag = arrays.rows, arrays.indices, arrays.diag
        ap_scaled, at, storage, source = arrays.ap, arrays.at, arrays.storage, arrays.rhs
        full = start.full.copy()
        u = np.where(full, start.pressure_pa / self.p_ref, start.fill_fraction)
        tol_p = 1e-10 * self.p_ref
        seen: set[bytes] = set()
        linear = 0
        for iteration in range(1, max_iterations + 1):  # noqa: B007 (the count is returned)
            cav = ~full
            data = np.where(full[cols], ap_scaled, at)
            data[diag] += storage * cav
            rhs = source - np.bincount(rows, weights=at * full[cols], minlength=grid.n_nodes)
            rhs -= storage * full
            u, its = self._linear_solve(data, rhs, u, LINEAR_TOLERANCE * self.couette_scale_m3_s)
            linear += its
            p = np.where(full, u * self.p_ref, 0.0)
            theta = np.where(full, 1.0, u)
            new_full = full.copy()
            new_full[full & (p < -tol_p)] = False
            new_full[cav & (theta > 1.0 + 1e-10)] = True
            if np.array_equal(new_full, full):
                break
            key = np.packbits(new_full).tobytes()
            if key in seen:
                new_full = full.copy()
                worst_p = np.where(full, p, np.inf).argmin()
                worst_t = np.where(cav, theta, -np.inf).argmax()
                if -p[worst_p] / self.p_ref >= theta[worst_t] - 1.0:
                    new_full[worst_p] = False
                else:
                    new_full[worst_t] = True
            seen.add(key)
            u = np.where(new_full & ~full, 0.0, np.where(~new_full & full, 1.0, u))
            full = new_full
        else:
            raise RuntimeError(
                f"transient film step did not converge in {max_iterations} active-set iterations"
            )
        return p, theta, full, iteration, linear

    def _linear_solve(self, data, rhs, guess, atol: float) -> tuple[np.ndarray, int]:
        """Solve M u = rhs (M as CSR data on the grid pattern) by GMRES preconditioned with a reused LU."""
        grid = self.grid
        n = grid.n_nodes
        matrix = sp.csr_matrix((data, grid.pattern.indices, grid.pattern.indptr), shape=(n, n))
        if self._lu is not None:
            lu = self._lu
            preconditioner = LinearOperator((n, n), matvec=lambda v: lu.solve(v, trans="T"))
            count = [0]

            def tick(_):
                count[0] += 1

            u, info = gmres(
                matrix,
                rhs,
                x0=guess,
                rtol=1e-14,
                atol=atol,
                restart=REFACTOR_ITERATIONS,
                maxiter=1,
                M=preconditioner,
                callback=tick,
                callback_type="pr_norm",
            )
            if info == 0 and count[0] < REFACTOR_ITERATIONS:
                return u, count[0]
        mt = sp.csc_matrix((data, grid.pattern.indices, grid.pattern.indptr), shape=(n, n))
        self._lu = splu(
            mt, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
        )
        self.factorizations += 1
        return self._lu.solve(rhs, trans="T"), 0


def extrapolated_start(state: TransientFilmState) -> ActiveSetStart:
    """The start of a step: the film extrapolated linearly in time from its last two steps (the
    journal moves smoothly, so this halves or better the residual the solver has to remove), or the
    state itself before its second step. The partition follows the extrapolated pressure."""
    if state.previous_pressure_pa is None:
        return ActiveSetStart(state.pressure_pa, state.fill_fraction, state.full)
    p = 2.0 * state.pressure_pa - state.previous_pressure_pa
    theta = np.clip(2.0 * state.fill_fraction - state.previous_fill_fraction, 0.0, 1.0)
    full = p > 0.0
    return ActiveSetStart(np.maximum(p, 0.0), np.where(full, 1.0, np.minimum(theta, 1.0 - 1e-12)), full)
