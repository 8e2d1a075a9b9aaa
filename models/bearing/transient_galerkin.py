"""The masked Galerkin coarse operators of the transient multigrid: full build and incremental update.

:mod:`oilwatch.models.bearing.transient_multigrid` corrects the pressure on the full volumes F with the
Galerkin hierarchy A_{l+1} = P^T A_l[F_l, F_l] P of piecewise-constant aggregation (F_{l+1}: the
aggregates with a member in F_l; an aggregate without one gets a unit diagonal, its correction is
zero). Within a step the Poiseuille matrix is fixed and only F moves, a few volumes per cycle near
the cavitation fronts, so after the first build of a step :func:`update` recomputes only the coarse
entries that an entry of a switched volume (its row or its column) feeds, level after level; the
recomputed entries of one level are the changed entries the next level starts from. Every entry is
recomputed from its members in the full build's order, so the update is bitwise the full build.

The kernels take the hierarchy as :class:`oilwatch.models.bearing.transient_multigrid.LevelArrays` and the
step's fine arrays as :class:`oilwatch.models.bearing.transient_kernels.StepArrays`.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _galerkin(indptr, indices, data, mask, slot_of, parent, coarse_data, coarse_mask, coarse_diag, count):
    """coarse = P^T A[mask, mask] P for piecewise-constant P on the masked nodes; coarse nodes
    without a masked member get a unit diagonal (their correction is zero). ``count``: the masked
    members of every coarse node."""
    coarse_data[:] = 0.0
    coarse_mask[:] = False
    count[:] = 0
    for k in range(indptr.size - 1):
        if not mask[k]:
            continue
        c = np.uint64(parent[k])  # unsigned indices, as in transient_sweep
        coarse_mask[c] = True
        count[c] += 1
        for s in range(np.uint64(indptr[k]), np.uint64(indptr[k + 1])):
            if mask[np.uint64(indices[s])]:
                coarse_data[np.uint64(slot_of[s])] += data[s]
    for c in range(coarse_mask.size):
        if not coarse_mask[c]:
            coarse_data[coarse_diag[c]] = 1.0


@njit(cache=True)
def _invert_coarsest(h) -> None:
    """The Cholesky factor L (lower) of the coarsest operator into ``h.coarsest``: the masked
    Laplacian is irreducibly diagonally dominant (its diagonal keeps the faces to cavitated volumes
    and the bearing ends), its Galerkin products and unit diagonals symmetric positive definite."""
    last = len(h.data) - 1
    n = h.x[last].size
    dense = np.zeros((n, n))
    for row in range(n):
        for s in range(h.indptr[last][row], h.indptr[last][row + 1]):
            dense[row, h.indices[last][s]] = h.data[last][s]
    h.coarsest[:, :] = np.linalg.cholesky(dense)


@njit(cache=True)
def coarsest_solve(factor, b, x) -> None:
    """x = (L L^T)^-1 b for the lower Cholesky ``factor`` L."""
    n = b.size
    for i in range(n):
        total = b[i]
        for j in range(i):
            total -= factor[i, j] * x[j]
        x[i] = total / factor[i, i]
    for i in range(n - 1, -1, -1):
        total = x[i]
        for j in range(i + 1, n):
            total -= factor[j, i] * x[j]
        x[i] = total / factor[i, i]


@njit(cache=True)
def build(h, k, full) -> None:
    """The coarse operators of the step's Poiseuille matrix on the volumes ``full``, from scratch."""
    indptr, indices, data, mask = k.indptr, k.indices, k.ap, full
    for i in range(len(h.data)):
        _galerkin(
            indptr,
            indices,
            data,
            mask,
            h.slot_of[i],
            h.parent[i],
            h.data[i],
            h.mask[i],
            h.diag[i],
            h.count[i],
        )
        indptr, indices, data, mask = h.indptr[i], h.indices[i], h.data[i], h.mask[i]
    _invert_coarsest(h)


@njit(cache=True)
def _mark(slot, flag, affected, n_affected):
    if not flag[slot]:
        flag[slot] = True
        affected[n_affected] = slot
        n_affected += 1
    return n_affected


@njit(cache=True)
def update(h, k, full, switched, n_switched) -> None:
    """The coarse operators after the volumes ``switched[:n_switched]`` changed state in ``full``
    (already updated) since the last :func:`build` / :func:`update` with the same Poiseuille matrix."""
    indptr, indices, data, mask = k.indptr, k.indices, k.ap, full
    rows, transpose = k.rows, k.transpose
    nodes = switched[:n_switched]
    changed_slots = np.empty(0, dtype=np.int64)
    for i in range(len(h.data)):
        slot_of, parent = h.slot_of[i], h.parent[i]
        c_data, c_mask, count = h.data[i], h.mask[i], h.count[i]
        flag, affected = h.flag[i], h.affected[i]
        n_affected = 0
        for k_node in nodes:
            for s in range(indptr[k_node], indptr[k_node + 1]):
                n_affected = _mark(slot_of[s], flag, affected, n_affected)
                n_affected = _mark(slot_of[transpose[s]], flag, affected, n_affected)
        for s in changed_slots:
            n_affected = _mark(slot_of[s], flag, affected, n_affected)
        # The aggregates of the switched nodes: their masked-member counts, and which switched.
        parents = h.switched[i]
        n_parents = 0
        for k_node in nodes:
            c = parent[k_node]
            count[c] += 1 if mask[k_node] else -1
        for k_node in nodes:
            c = parent[k_node]
            if (count[c] > 0) != c_mask[c]:
                c_mask[c] = count[c] > 0
                parents[n_parents] = c
                n_parents += 1
        member_ptr, member_slots = h.member_ptr[i], h.member_slots[i]
        c_rows, c_indices = h.rows[i], h.indices[i]
        for a in range(n_affected):
            cs = affected[a]
            flag[cs] = False
            total = 0.0
            for m in range(np.uint64(member_ptr[cs]), np.uint64(member_ptr[cs + 1])):
                s = np.uint64(member_slots[m])
                if mask[np.uint64(rows[s])] and mask[np.uint64(indices[s])]:
                    total += data[s]
            row = c_rows[cs]
            if row == c_indices[cs] and not c_mask[row]:
                total = 1.0
            c_data[cs] = total
        indptr, indices, data, mask = h.indptr[i], c_indices, c_data, c_mask
        rows, transpose = c_rows, h.transpose[i]
        nodes = parents[:n_parents]
        changed_slots = affected[:n_affected]
    _invert_coarsest(h)
