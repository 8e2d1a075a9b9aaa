"""Multigrid for the transient film step: projected Gauss-Seidel plus an aggregation coarse correction.

The step of :class:`models.bearing.transient.TransientFilm` is the mixed complementarity problem of
:mod:`models.bearing.transient_sweep` (pressure p >= 0 where the volume is full, fill fraction
theta <= 1 where it is cavitated). Projected SOR needs sweeps in proportion to the mesh's width
(the pressure is elliptic); on the production mesh (240 x 72) that is hundreds of sweeps a step.

Here (Brandt & Cryer, SIAM J. Sci. Stat. Comput. 4, 655, 1983, for the obstacle problem; Venner &
Lubrecht, "Multilevel Methods in Lubrication", Elsevier 2000, for cavitating films) the projected
Gauss-Seidel sweep of Ausas et al. stays the fine-level smoother: it moves the partition and
transports the fill fraction downstream. The smooth pressure error left by the sweeps is removed by
a linear coarse correction restricted to the pressurized region F (volumes full after the sweeps):
with the partition and theta held, the residual equation there is Ap[F, F] dp = r[F], a Poiseuille
Laplacian with p = 0 (Dirichlet) on the cavitated volumes and the bearing ends. Its hierarchy is
built by aggregation of 2 x 2 blocks of the tensor grid (the lumped groove is its own aggregate on
every level), the coarse operators by Galerkin products P^T A P of the masked operator: they follow
any partition without geometry of their own, and the masked Laplacian stays symmetric positive
definite on every level. Piecewise-constant prolongation makes the Galerkin operator about twice too
stiff for a Laplacian, so each coarse correction is over-relaxed by :data:`COARSE_SCALE` (Blaheta's
over-correction; Vanek, Mandel & Brezina, Computing 56, 179, 1996, for the stiffness argument).

Cycle: one projected sweep that leaves its residual behind (the acceptance test: every volume's balance
and the step's mass balance, as for the sweeps alone), then one V-cycle on the residual equation of F
(symmetric Gauss-Seidel on the coarse levels, a dense solve on the coarsest) added to p on F.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numba import njit

from .grid import FilmGrid
from .transient_kernels import StepArrays
from .transient_sweep import projected_sweep_residual, step_residual, sweep_factors

COARSE_SCALE = 1.7
"""Over-correction of every piecewise-constant coarse correction (1 would be the plain Galerkin one)."""
COARSEST_NODES = 80
"""The hierarchy stops at a level with at most this many nodes, solved densely."""


@dataclass(frozen=True, eq=False)
class Level:
    """One coarse level: CSR pattern (indptr, indices, diag slots), the aggregate of every node of the
    level above (``parent``) and the coarse slot of every entry of the level above (``slot_of``)."""

    n: int
    indptr: np.ndarray
    indices: np.ndarray
    diag: np.ndarray
    parent: np.ndarray
    slot_of: np.ndarray
    scale: np.ndarray


def _coarsen(indptr, indices, coords, groove: int):
    """Aggregate 2 x 2 blocks of (i, j) ``coords`` (the node ``groove`` alone): the coarse level."""
    n = indptr.size - 1
    key = (coords[:, 0] // 2) * (coords[:, 1].max() + 2) + coords[:, 1] // 2
    key = np.where(np.arange(n) == groove, -1, key)
    unique, parent = np.unique(key, return_inverse=True)
    n_coarse = unique.size
    rows = np.repeat(np.arange(n), np.diff(indptr))
    pair = parent[rows].astype(np.int64) * n_coarse + parent[indices]
    pairs, slot_of = np.unique(pair, return_inverse=True)
    c_rows, c_cols = pairs // n_coarse, pairs % n_coarse
    c_indptr = np.concatenate([[0], np.cumsum(np.bincount(c_rows, minlength=n_coarse))]).astype(np.int64)
    diag = np.searchsorted(pairs, np.arange(n_coarse) * n_coarse + np.arange(n_coarse))
    first = np.zeros(n_coarse, dtype=np.int64)
    first[parent] = np.arange(n)  # any member: the block coordinates are the same
    c_coords = coords[first] // 2
    c_groove = int(parent[groove])
    # The groove is a single volume on every level: its correction is exact, not over-relaxed.
    scale = np.full(n_coarse, COARSE_SCALE)
    scale[c_groove] = 1.0
    level = Level(
        n_coarse,
        c_indptr,
        c_cols.astype(np.int64),
        diag.astype(np.int64),
        parent.astype(np.int64),
        slot_of.astype(np.int64),
        scale,
    )
    return level, c_coords, c_groove


@lru_cache(maxsize=8)
def hierarchy(grid: FilmGrid) -> tuple[Level, ...]:
    """The aggregation levels of ``grid`` (cached per grid), finest first."""
    n, m = grid.in_groove.shape
    coords = np.zeros((grid.n_nodes, 2), dtype=np.int64)
    cells_i, cells_j = np.meshgrid(np.arange(n), np.arange(m), indexing="ij")
    land = ~grid.in_groove
    coords[grid.node_of_cell[land]] = np.stack([cells_i[land], cells_j[land]], axis=1)
    indptr = grid.pattern.indptr.astype(np.int64)
    indices = grid.pattern.indices.astype(np.int64)
    groove = grid.groove_node
    levels = []
    while indptr.size - 1 > COARSEST_NODES:
        level, coords, groove = _coarsen(indptr, indices, coords, groove)
        levels.append(level)
        indptr, indices = level.indptr, level.indices
    return tuple(levels)


@njit(cache=True)
def _galerkin(indptr, indices, data, mask, slot_of, parent, coarse_data, coarse_mask, coarse_diag):
    """coarse = P^T A[mask, mask] P for piecewise-constant P on the masked nodes; coarse nodes
    without a masked member get a unit diagonal (their correction is zero)."""
    coarse_data[:] = 0.0
    coarse_mask[:] = False
    for k in range(indptr.size - 1):
        if not mask[k]:
            continue
        coarse_mask[parent[k]] = True
        for s in range(indptr[k], indptr[k + 1]):
            if mask[indices[s]]:
                coarse_data[slot_of[s]] += data[s]
    for c in range(coarse_mask.size):
        if not coarse_mask[c]:
            coarse_data[coarse_diag[c]] = 1.0


@njit(cache=True)
def _restrict(r, mask, parent, out):
    out[:] = 0.0
    for k in range(r.size):
        if mask[k]:
            out[parent[k]] += r[k]


@njit(cache=True)
def _prolong(x, mask, parent, coarse, scale):
    for k in range(x.size):
        if mask[k]:
            c = parent[k]
            x[k] += scale[c] * coarse[c]


@njit(cache=True)
def _gauss_seidel(indptr, indices, data, diag, mask, x, b, forward):
    """One linear Gauss-Seidel sweep on the masked rows (the masked data hold no other columns)."""
    n = x.size
    for kk in range(n):
        k = kk if forward else n - 1 - kk
        if not mask[k]:
            continue
        total = b[k]
        for s in range(indptr[k], indptr[k + 1]):
            total -= data[s] * x[indices[s]]
        d = data[diag[k]]
        x[k] = (total + d * x[k]) / d


@njit(cache=True)
def _masked_residual(indptr, indices, data, mask, x, b, out):
    """out = (b - A[mask, mask] x) on the masked rows, 0 elsewhere (A's other columns ignored)."""
    for k in range(x.size):
        total = 0.0
        if mask[k]:
            total = b[k]
            for s in range(indptr[k], indptr[k + 1]):
                j = indices[s]
                if mask[j]:
                    total -= data[s] * x[j]
        out[k] = total


class CoarseCorrection:
    """The masked Galerkin hierarchy of one film grid and its V-cycle (work arrays kept between steps)."""

    def __init__(self, grid: FilmGrid, smoothing: int = 1):
        self.levels = hierarchy(grid)
        self.smoothing = smoothing
        self.data = [np.zeros(lv.indices.size) for lv in self.levels]
        self.mask = [np.zeros(lv.n, dtype=np.bool_) for lv in self.levels]
        self.x = [np.zeros(lv.n) for lv in self.levels]
        self.b = [np.zeros(lv.n) for lv in self.levels]
        self.r = [np.zeros(lv.n) for lv in self.levels]
        self._coarsest = None
        n1 = self.levels[0].n
        self.zero1, self._unit = np.zeros(n1), np.ones(n1)

    def build(self, k: StepArrays, full) -> None:
        """The coarse operators of the step's Poiseuille matrix on the volumes ``full``."""
        indptr, indices, data, mask = k.indptr, k.indices, k.ap, full
        for lv, c_data, c_mask in zip(self.levels, self.data, self.mask, strict=True):
            _galerkin(indptr, indices, data, mask, lv.slot_of, lv.parent, c_data, c_mask, lv.diag)
            indptr, indices, data, mask = lv.indptr, lv.indices, c_data, c_mask
        last = self.levels[-1]
        dense = np.zeros((last.n, last.n))
        rows = np.repeat(np.arange(last.n), np.diff(last.indptr))
        dense[rows, last.indices] = self.data[-1]
        self._coarsest = np.linalg.inv(dense)

    def correct(self, p, residual, full) -> None:
        """p[full] += the V-cycle's correction for ``residual`` on the full volumes, with the step
        length that minimises the error's energy norm along it (Ap[F, F] is symmetric positive
        definite; the over-corrected coarse levels are only approximately right for every mode)."""
        levels = self.levels
        _restrict(residual, full, levels[0].parent, self.b[0])
        depth = len(levels)
        for i in range(depth - 1):
            lv, x, b = levels[i], self.x[i], self.b[i]
            x[:] = 0.0
            for _ in range(self.smoothing):
                _gauss_seidel(lv.indptr, lv.indices, self.data[i], lv.diag, self.mask[i], x, b, True)
            _masked_residual(lv.indptr, lv.indices, self.data[i], self.mask[i], x, b, self.r[i])
            _restrict(self.r[i], self.mask[i], levels[i + 1].parent, self.b[i + 1])
        self.x[-1][:] = self._coarsest @ self.b[-1]
        for i in range(depth - 2, -1, -1):
            lv = levels[i]
            _prolong(self.x[i], self.mask[i], levels[i + 1].parent, self.x[i + 1], levels[i + 1].scale)
            for _ in range(self.smoothing):
                _gauss_seidel(
                    lv.indptr, lv.indices, self.data[i], lv.diag, self.mask[i], self.x[i], self.b[i], False
                )
        # d = P (scale x): its curvature d^T Ap[F, F] d and d^T r[F] are exact on the first level
        # (A_1 = P^T Ap[F, F] P, b_1 = P^T r[F]), so the step length costs no fine-level pass.
        first = levels[0]
        y = first.scale * self.x[0]
        _masked_residual(first.indptr, first.indices, self.data[0], self.mask[0], y, self.zero1, self.r[0])
        curvature = -(y @ self.r[0])
        step = (y @ self.b[0]) / curvature if curvature > 0.0 else 0.0
        _prolong(p, full, first.parent, y, step * self._unit)


def multigrid_solve(
    correction: CoarseCorrection,
    k: StepArrays,
    p,
    theta,
    residual_limit: float,
    mass_limit: float,
    max_cycles: int,
    relaxation: float = 1.0,
):
    """Projected multigrid cycles in place on ``p`` (scaled pressure) and ``theta``.

    Same acceptance as :func:`models.bearing.transient_sweep.sor_sweeps`, judged on the residual the
    sweep leaves (:func:`~models.bearing.transient_sweep.projected_sweep_residual`) and confirmed by
    a fresh residual pass. Returns (cycles, max |r|, sum r, converged); a converged warm start costs
    one residual pass."""
    work = np.empty(p.size)
    worst, total = step_residual(k, p, theta, work)
    if worst <= residual_limit and abs(total) <= mass_limit:
        return 0, worst, total, True
    factors = sweep_factors(k)
    mask = None
    for cycle in range(1, max_cycles + 1):
        worst, total = projected_sweep_residual(k, factors, p, theta, relaxation, work)
        if worst <= residual_limit and abs(total) <= mass_limit:
            worst, total = step_residual(k, p, theta, work)
            if worst <= residual_limit and abs(total) <= mass_limit:
                return cycle, worst, total, True
        full = theta >= 1.0
        if mask is None or not np.array_equal(full, mask):
            mask = full
            correction.build(k, mask)
        correction.correct(p, work, mask)
    return max_cycles, worst, total, False
