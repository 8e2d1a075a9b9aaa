"""Multigrid for the transient film step: projected Gauss-Seidel plus an aggregation coarse correction.

The step of :class:`oilwatch.models.bearing.transient.TransientFilm` is the mixed complementarity problem of
:mod:`oilwatch.models.bearing.transient_sweep` (pressure p >= 0 where the volume is full, fill fraction
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

Cycle: one projected sweep (over-relaxed, :data:`RELAXATION`) that leaves its residual behind (the
acceptance test: every volume's balance and the step's mass balance, as for the sweeps alone), then
one V-cycle on the residual equation of F (symmetric Gauss-Seidel on the coarse levels, a dense solve
on the coarsest) added to p on F.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit

from .grid import FilmGrid
from .transient_galerkin import build as build_coarse
from .transient_galerkin import coarsest_solve
from .transient_galerkin import update as update_coarse
from .transient_kernels import StepArrays, transpose_slots
from .transient_sweep import conserve_mass, projected_sweep_residual, step_residual, sweep_factors

COARSE_SCALE = 1.7
"""Over-correction of every piecewise-constant coarse correction (1 would be the plain Galerkin one)."""
RELAXATION = 1.2
"""Over-relaxation of the full volumes' pressure in the cycle's projected sweep. The coarse correction
holds the fill fraction, so the mode that couples a front's pressures to the fill next to it is left
to the sweeps, which over-relaxation speeds up. Mean cycles per bearing-step, 240 x 72 half film,
3 um whirl, plant tolerances (1e-8 / 1e-7): 1.0: 18.6, 1.15: 15.8, 1.2: 15.0, 1.3: 15.7, 1.4: 18.1,
1.5: 22.8; at the studies' tolerances (1e-11 / 1e-10) 30.8 -> 23.5, on 120 x 36 15.6 -> 13.3."""
COARSEST_NODES = 80
"""The hierarchy stops at a level with at most this many nodes, solved densely."""


@dataclass(frozen=True, eq=False)
class Level:
    """One coarse level: CSR pattern (indptr, indices, diag slots, row and transpose slot of every
    entry), the aggregate of every node of the level above (``parent``), the coarse slot of every
    entry of the level above (``slot_of``) and, per coarse slot, the entries of the level above that
    sum into it (``member_slots[member_ptr[s]:member_ptr[s + 1]]``, ascending: a slot recomputed
    from them is bitwise the full Galerkin product's)."""

    n: int
    indptr: np.ndarray
    indices: np.ndarray
    diag: np.ndarray
    parent: np.ndarray
    slot_of: np.ndarray
    scale: np.ndarray
    rows: np.ndarray
    transpose: np.ndarray
    member_ptr: np.ndarray
    member_slots: np.ndarray


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
    c_cols = c_cols.astype(np.int64)
    pattern = sp.csr_matrix((np.ones(c_cols.size), c_cols, c_indptr), shape=(n_coarse, n_coarse))
    slot_of = slot_of.astype(np.int64).ravel()
    level = Level(
        n_coarse,
        c_indptr,
        c_cols,
        diag.astype(np.int64),
        parent.astype(np.int64),
        slot_of,
        scale,
        c_rows.astype(np.int64),
        transpose_slots(pattern),
        np.concatenate([[0], np.cumsum(np.bincount(slot_of, minlength=c_cols.size))]).astype(np.int64),
        np.argsort(slot_of, kind="stable").astype(np.int64),
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
def _restrict(r, mask, parent, out):
    out[:] = 0.0
    for k in range(r.size):
        if mask[k]:
            out[np.uint64(parent[k])] += r[k]


@njit(cache=True)
def _prolong(x, mask, parent, coarse, scale):
    for k in range(x.size):
        if mask[k]:
            c = np.uint64(parent[k])
            x[k] += scale[c] * coarse[c]


@njit(cache=True)
def _gauss_seidel(indptr, indices, data, diag, mask, x, b, forward):
    """One linear Gauss-Seidel sweep on the masked rows (the masked data hold no other columns).
    As in the projected sweep, the neighbour updated just before a row (the slot left of the diagonal
    forward, right of it backward) enters last and the division is a multiplication by the diagonal's
    inverse, computed off that chain: the sweep waits on it at every row. Unsigned indices, as in
    :mod:`oilwatch.models.bearing.transient_sweep`."""
    n = x.size
    one = np.uint64(1)
    for kk in range(n):
        k = np.uint64(kk if forward else n - 1 - kk)
        if not mask[k]:
            continue
        first, end, d = np.uint64(indptr[k]), np.uint64(indptr[k + one]), np.uint64(diag[k])
        if forward:
            t = d - one if d > first else d
        else:
            t = d + one if d + one < end else d
        inverse = 1.0 / data[d]
        total = b[k]
        for s in range(first, end):
            if s != d and s != t:
                total -= data[s] * x[np.uint64(indices[s])]
        latest = data[t] * x[np.uint64(indices[t])] if t != d else 0.0
        x[k] = (total - latest) * inverse


@njit(cache=True)
def _masked_residual(indptr, indices, data, mask, x, b, out):
    """out = (b - A[mask, mask] x) on the masked rows, 0 elsewhere (A's other columns ignored)."""
    for k in range(x.size):
        total = 0.0
        if mask[k]:
            total = b[k]
            for s in range(np.uint64(indptr[k]), np.uint64(indptr[k + 1])):
                j = np.uint64(indices[s])
                if mask[j]:
                    total -= data[s] * x[j]
        out[k] = total


class LevelArrays(NamedTuple):
    """The coarse levels of a :class:`CoarseCorrection` for the compiled cycle: per level (finest
    first) its pattern, ``parent`` and ``slot_of`` maps and over-correction ``scale``, and the work
    arrays (Galerkin ``data``, ``mask`` of levels with a full member, ``x``, ``b``, ``r``);
    ``coarsest`` the Cholesky factor of the last level's operator. For the incremental update of
    :mod:`oilwatch.models.bearing.transient_galerkin`: per level its entries' ``rows`` and ``transpose``
    slots, the ``member_ptr`` / ``member_slots`` of every entry, the full-member ``count`` of every
    node, and work arrays (``flag`` and ``affected`` entries, ``switched`` nodes)."""

    indptr: tuple
    indices: tuple
    diag: tuple
    parent: tuple
    slot_of: tuple
    scale: tuple
    data: tuple
    mask: tuple
    x: tuple
    b: tuple
    r: tuple
    coarsest: np.ndarray
    rows: tuple
    transpose: tuple
    member_ptr: tuple
    member_slots: tuple
    count: tuple
    flag: tuple
    affected: tuple
    switched: tuple


class CoarseCorrection:
    """The masked Galerkin hierarchy of one film grid and its work arrays, kept between steps."""

    def __init__(self, grid: FilmGrid, smoothing: int = 1):
        levels = hierarchy(grid)
        self.smoothing = smoothing

        def each(make):
            return tuple(make(lv) for lv in levels)

        self.arrays = LevelArrays(
            indptr=each(lambda lv: lv.indptr),
            indices=each(lambda lv: lv.indices),
            diag=each(lambda lv: lv.diag),
            parent=each(lambda lv: lv.parent),
            slot_of=each(lambda lv: lv.slot_of),
            scale=each(lambda lv: lv.scale),
            data=each(lambda lv: np.zeros(lv.indices.size)),
            mask=each(lambda lv: np.zeros(lv.n, dtype=np.bool_)),
            x=each(lambda lv: np.zeros(lv.n)),
            b=each(lambda lv: np.zeros(lv.n)),
            r=each(lambda lv: np.zeros(lv.n)),
            coarsest=np.zeros((levels[-1].n, levels[-1].n)),
            rows=each(lambda lv: lv.rows),
            transpose=each(lambda lv: lv.transpose),
            member_ptr=each(lambda lv: lv.member_ptr),
            member_slots=each(lambda lv: lv.member_slots),
            count=each(lambda lv: np.zeros(lv.n, dtype=np.int64)),
            flag=each(lambda lv: np.zeros(lv.indices.size, dtype=np.bool_)),
            affected=each(lambda lv: np.zeros(lv.indices.size, dtype=np.int64)),
            switched=each(lambda lv: np.zeros(lv.n, dtype=np.int64)),
        )


@njit(cache=True)
def v_cycle_correction(h: LevelArrays, p, residual, full, smoothing) -> None:
    """p[full] += the V-cycle's correction for ``residual`` on the full volumes, with the step
    length that minimises the error's energy norm along it (Ap[F, F] is symmetric positive
    definite; the over-corrected coarse levels are only approximately right for every mode)."""
    depth = len(h.data)
    _restrict(residual, full, h.parent[0], h.b[0])
    for i in range(depth - 1):
        x = h.x[i]
        x[:] = 0.0
        for _ in range(smoothing):
            _gauss_seidel(h.indptr[i], h.indices[i], h.data[i], h.diag[i], h.mask[i], x, h.b[i], True)
        _masked_residual(h.indptr[i], h.indices[i], h.data[i], h.mask[i], x, h.b[i], h.r[i])
        _restrict(h.r[i], h.mask[i], h.parent[i + 1], h.b[i + 1])
    coarsest_solve(h.coarsest, h.b[depth - 1], h.x[depth - 1])
    for i in range(depth - 2, -1, -1):
        _prolong(h.x[i], h.mask[i], h.parent[i + 1], h.x[i + 1], h.scale[i + 1])
        for _ in range(smoothing):
            _gauss_seidel(h.indptr[i], h.indices[i], h.data[i], h.diag[i], h.mask[i], h.x[i], h.b[i], False)
    # d = P (scale x): its curvature d^T Ap[F, F] d and d^T r[F] are exact on the first level
    # (A_1 = P^T Ap[F, F] P, b_1 = P^T r[F]), so the step length costs no fine-level pass.
    y = h.scale[0] * h.x[0]
    _masked_residual(h.indptr[0], h.indices[0], h.data[0], h.mask[0], y, np.zeros(y.size), h.r[0])
    curvature = -(y @ h.r[0])
    step = (y @ h.b[0]) / curvature if curvature > 0.0 else 0.0
    _prolong(p, full, h.parent[0], y, np.full(y.size, step))


def multigrid_solve(
    correction: CoarseCorrection,
    k: StepArrays,
    p,
    theta,
    residual_limit: float,
    mass_limit: float,
    max_cycles: int,
    relaxation: float = RELAXATION,
):
    """Projected multigrid cycles in place on ``p`` (scaled pressure) and ``theta``.

    Same acceptance as :func:`oilwatch.models.bearing.transient_sweep.sor_sweeps`, judged on the residual the
    sweep leaves (:func:`~oilwatch.models.bearing.transient_sweep.projected_sweep_residual`) and confirmed by
    a fresh residual pass; when only the mass balance fails, the mass correction
    (:func:`~oilwatch.models.bearing.transient_sweep.conserve_mass`) is tried. Returns (cycles, max |r|, sum
    r, converged); a converged warm start costs one residual pass."""
    h = correction.arrays
    return _cycles(h, k, p, theta, residual_limit, mass_limit, max_cycles, relaxation, correction.smoothing)


@njit(cache=True)
def _cycles(h, k, p, theta, residual_limit, mass_limit, max_cycles, relaxation, smoothing):
    n = p.size
    work = np.empty(n)
    worst, total = step_residual(k, p, theta, work)
    if worst <= residual_limit and abs(total) <= mass_limit:
        return 0, worst, total, True
    factors = sweep_factors(k)
    mask = np.zeros(n, dtype=np.bool_)
    switched = np.empty(n, dtype=np.int64)
    built = False
    for cycle in range(1, max_cycles + 1):
        worst, total = projected_sweep_residual(k, factors, p, theta, relaxation, work)
        if worst <= residual_limit and abs(total) <= mass_limit:
            worst, total = step_residual(k, p, theta, work)
            if worst <= residual_limit and abs(total) <= mass_limit:
                return cycle, worst, total, True
        elif worst <= residual_limit:
            worst, total, accepted = conserve_mass(k, p, theta, work, residual_limit, mass_limit)
            if accepted:
                return cycle, worst, total, True
        n_switched = 0
        for i in range(n):
            full = theta[i] >= 1.0
            if full != mask[i]:
                mask[i] = full
                switched[n_switched] = i
                n_switched += 1
        if not built:
            build_coarse(h, k, mask)
            built = True
        elif n_switched > 0:
            update_coarse(h, k, mask, switched, n_switched)
        v_cycle_correction(h, p, work, mask, smoothing)
    return max_cycles, worst, total, False
