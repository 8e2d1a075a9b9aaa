"""The arrays of one transient film step, shared by its three solvers, and their compiled assembly.

Every solver of :class:`oilwatch.models.bearing.transient.TransientFilm` (the projected multigrid of
:mod:`oilwatch.models.bearing.transient_multigrid`, the projected SOR sweeps of
:mod:`oilwatch.models.bearing.transient_sweep` and the active-set fallback) works on the same balance of every
control volume k,

    sum_j Ap[k, j] p_j + sum_j At[k, j] theta_j + S_k theta_k = b_k,    S_k = beta V_k / dt,

with the scaled pressure p / p_ref. :class:`StepArrays` holds its arrays: the fixed CSR pattern of the
grid (with the slot of every entry's transpose, for the sweep that keeps the residual), and the
coefficients, refilled in place every step. It is a ``NamedTuple`` so the compiled kernels take it as
one argument.

The projected sweeps read the same coefficients as fixed-width rows (:func:`sweep_rows`): every land
volume of the structured grid has at most four neighbours, so its row is four (column, coefficient)
pairs in the order the sweep subtracts them, padded with zeros, and the sweep runs without the CSR
row bounds, with unsigned columns (no negative-index wraparound in the compiled loop) and its
coefficients in one contiguous stream. The same arithmetic in the same order: the sweeps' iterates
are bitwise those of the CSR rows (tested). The lumped groove, coupled to its whole rim, keeps its
CSR row.

:class:`StepAssembly` fills Ap and At for a journal position with the same face quadrature as
:func:`oilwatch.models.bearing.discretization.film_operator` (h^3 / (12 mu) at the faces, upwind Couette flow
(U / 2) h), in one compiled pass over the faces instead of a numpy assembly per step (tested equal).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit

from .grid import FilmGrid

SWEEP_WIDTH = 4
"""Off-diagonal entries of a land volume's row (its circumferential and axial neighbours)."""


class StepArrays(NamedTuple):
    """Pattern (indptr, indices, diag, rows, transpose: the slot of entry (j, k) for the slot of (k, j))
    and the step's coefficients: ap (nnz,) Poiseuille [m^3/s per scaled pressure], at (nnz,) Couette
    [m^3/s], storage (n,) S_k [m^3/s] and rhs (n,) b_k [m^3/s]; at_transpose (nnz,) the Couette entry
    of every slot's transpose, ``at[transpose]`` (Ap is symmetric, bitwise: each face adds the same
    conductance to both of its slots), so the sweep that keeps its residual reads both row-wise.
    The sweep's rows of the volumes but the last (:func:`sweep_rows`): ``sweep_cols`` (n - 1, 4)
    unsigned columns, ``sweep_slots`` (n - 1, 4) their CSR slots (-1: padding), ``sweep_csr``
    the rows that do not fit, ascending (all padding; swept from their CSR rows) and ``sweep_coef``
    (n - 1, 12) their ap, at and at_transpose entries (padding 0), refilled with them."""

    indptr: np.ndarray
    indices: np.ndarray
    diag: np.ndarray
    rows: np.ndarray
    transpose: np.ndarray
    ap: np.ndarray
    at: np.ndarray
    storage: np.ndarray
    rhs: np.ndarray
    at_transpose: np.ndarray
    sweep_cols: np.ndarray
    sweep_slots: np.ndarray
    sweep_csr: np.ndarray
    sweep_coef: np.ndarray


def transpose_slots(pattern: sp.csr_matrix) -> np.ndarray:
    """For every slot of the (structurally symmetric) CSR ``pattern``, the slot of its transpose."""
    slots = sp.csr_matrix(
        (np.arange(pattern.nnz) + 1.0, pattern.indices, pattern.indptr), shape=pattern.shape
    )
    flipped = slots.T.tocsr()
    flipped.sort_indices()
    if not (
        np.array_equal(flipped.indptr, pattern.indptr) and np.array_equal(flipped.indices, pattern.indices)
    ):
        raise ValueError("the film grid's pattern is not structurally symmetric")
    return flipped.data.astype(np.int64) - 1


@njit(cache=True)
def sweep_rows(indptr, indices, diag):
    """The sweep's fixed-width rows of every volume but the last (the groove): per row the CSR slots
    of its off-diagonal entries in the order the sweep subtracts them (those left of the diagonal but
    the nearest, those right of it, then the nearest left of it: the volume updated just before, whose
    flow enters last), padded to :data:`SWEEP_WIDTH` (own column, slot -1) before that last one. A row
    whose entries do not fit (four right of the diagonal: a volume of the whole film's first column
    next to the groove) is all padding and listed. Returns (columns (n - 1, 4) uint32, slots
    (n - 1, 4) int64, the rows that do not fit (int64, ascending))."""
    n = indptr.size - 1
    cols = np.empty((n - 1, SWEEP_WIDTH), dtype=np.uint32)
    slots = np.full((n - 1, SWEEP_WIDTH), -1, dtype=np.int64)
    csr = np.zeros(n - 1, dtype=np.bool_)
    for i in range(n - 1):
        first, d, end = indptr[i], diag[i], indptr[i + 1]
        latest = d - 1 if d > first else -1
        c = 0
        for s in range(first, end):
            if s != d and s != latest:
                if c < SWEEP_WIDTH - 1:
                    slots[i, c] = s
                c += 1
        slots[i, SWEEP_WIDTH - 1] = latest
        if c > SWEEP_WIDTH - 1:
            csr[i] = True
            slots[i, :] = -1
        for c in range(SWEEP_WIDTH):
            cols[i, c] = indices[slots[i, c]] if slots[i, c] >= 0 else i
    return cols, slots, np.flatnonzero(csr)


@njit(cache=True)
def _gather_rows(ap, at, at_transpose, slots, coef):
    """coef[i] = (ap, at, at_transpose) of the slots of row i (padding left at 0)."""
    for i in range(slots.shape[0]):
        for c in range(SWEEP_WIDTH):
            s = slots[i, c]
            if s >= 0:
                coef[i, c] = ap[s]
                coef[i, SWEEP_WIDTH + c] = at[s]
                coef[i, 2 * SWEEP_WIDTH + c] = at_transpose[s]


class StepAssembly:
    """The face geometry of one film grid, and :meth:`fill` of a step's Ap and At for a position.

    ``p_ref`` [Pa] scales the pressure unknown (Ap is stored per scaled pressure); ``omega_rad_s``
    the spin speed. ``end_nodes`` and :meth:`side_leakage` give the flow out of the bearing ends."""

    def __init__(self, grid: FilmGrid, viscosity_pa_s: float, omega_rad_s: float, p_ref: float):
        bearing = grid.bearing
        mu12 = 12.0 * viscosity_pa_s
        r = bearing.radius_m
        dpsi, dz = grid.dpsi, grid.dz
        slots = grid.slots
        self.clearance_m = bearing.clearance_m
        cf, af, ef = grid.circ_faces, grid.axial_faces, grid.end_faces
        alpha_f = grid.alpha_faces_rad[cf[:, 0]]
        self.circ = (
            np.cos(alpha_f),
            np.sin(alpha_f),
            p_ref * dz[cf[:, 1]] / grid.circ_dist / mu12,
            0.5 * omega_rad_s * r * dz[cf[:, 1]],
            slots["diag"][cf[:, 2]],
            slots["diag"][cf[:, 3]],
            slots["circ_ud"],
            slots["circ_du"],
        )
        alpha_a = grid.alpha_centres_rad[af[:, 0]]
        self.axial = (
            np.cos(alpha_a),
            np.sin(alpha_a),
            p_ref * r * dpsi[af[:, 0]] / grid.axial_dist / mu12,
            slots["diag"][af[:, 1]],
            slots["diag"][af[:, 2]],
            slots["axial_ud"],
            slots["axial_du"],
        )
        alpha_e = grid.alpha_centres_rad[ef[:, 0]]
        self.end_nodes = grid.node_of_cell[ef[:, 0], ef[:, 1]]
        self.ends = (
            np.cos(alpha_e),
            np.sin(alpha_e),
            p_ref * r * dpsi[ef[:, 0]] / grid.end_dist / mu12,
            slots["diag"][self.end_nodes],
        )
        self.end_conductance = np.zeros(self.end_nodes.size)
        """Conductance of every end volume to ambient at the last :meth:`fill` [m^3/s per scaled pressure]."""
        pattern = grid.pattern
        n = grid.n_nodes
        indptr, indices = pattern.indptr.astype(np.int64), pattern.indices.astype(np.int64)
        sweep_cols, sweep_slots, sweep_csr = sweep_rows(indptr, indices, slots["diag"])
        self.arrays = StepArrays(
            indptr=indptr,
            indices=indices,
            diag=slots["diag"],
            rows=slots["rows"],
            transpose=transpose_slots(pattern),
            ap=np.zeros(pattern.nnz),
            at=np.zeros(pattern.nnz),
            storage=np.zeros(n),
            rhs=np.zeros(n),
            at_transpose=np.zeros(pattern.nnz),
            sweep_cols=sweep_cols,
            sweep_slots=sweep_slots,
            sweep_csr=sweep_csr,
            sweep_coef=np.zeros((n - 1, 3 * SWEEP_WIDTH)),
        )

    def fill(self, ex: float, ey: float) -> StepArrays:
        """Ap and At of :attr:`arrays` for the journal at (ex, ey) [m], in place; returns the arrays."""
        a = self.arrays
        _fill(self.clearance_m, ex, ey, self.circ, self.axial, self.ends, a.ap, a.at, self.end_conductance)
        _gather(a.at, a.transpose, a.at_transpose)
        _gather_rows(a.ap, a.at, a.at_transpose, a.sweep_slots, a.sweep_coef)
        return a

    def side_leakage(self, p) -> float:
        """Flow out of the bearing ends [m^3/s] of the scaled pressure ``p`` at the last :meth:`fill`."""
        return float(self.end_conductance @ p[self.end_nodes])


@njit(cache=True)
def _film_thickness(clearance, ex, ey, cos_a, sin_a, out):
    for f in range(cos_a.size):
        out[f] = clearance - ex * cos_a[f] - ey * sin_a[f]


@njit(cache=True)
def _add_poiseuille(h, poiseuille, diag_a, diag_b, slot_ab, slot_ba, ap):
    """Ap += the conductance h^3 * poiseuille of every face between the volumes a and b."""
    for f in range(h.size):
        g = h[f] * h[f] * h[f] * poiseuille[f]
        ap[diag_a[f]] += g
        ap[diag_b[f]] += g
        ap[slot_ab[f]] -= g
        ap[slot_ba[f]] -= g


@njit(cache=True)
def _gather(values, slots, out):
    for s in range(out.size):
        out[s] = values[slots[s]]


@njit(cache=True)
def _fill(clearance, ex, ey, circ, axial, ends, ap, at, end_conductance):
    ap[:] = 0.0
    at[:] = 0.0
    cos_f, sin_f, poiseuille, couette, diag_up, diag_down, slot_ud, slot_du = circ
    h = np.empty(cos_f.size)
    _film_thickness(clearance, ex, ey, cos_f, sin_f, h)
    _add_poiseuille(h, poiseuille, diag_up, diag_down, slot_ud, slot_du, ap)
    for f in range(h.size):  # upwind Couette flow: out of the upstream volume, into the downstream one
        c = h[f] * couette[f]
        at[diag_up[f]] += c
        at[slot_du[f]] -= c
    cos_a, sin_a, poiseuille_a, diag_lo, diag_hi, slot_lh, slot_hl = axial
    h = np.empty(cos_a.size)
    _film_thickness(clearance, ex, ey, cos_a, sin_a, h)
    _add_poiseuille(h, poiseuille_a, diag_lo, diag_hi, slot_lh, slot_hl, ap)
    cos_e, sin_e, poiseuille_e, diag_end = ends
    h = np.empty(cos_e.size)
    _film_thickness(clearance, ex, ey, cos_e, sin_e, h)
    for f in range(h.size):
        g = h[f] * h[f] * h[f] * poiseuille_e[f]
        ap[diag_end[f]] += g
        end_conductance[f] = g


@njit(cache=True)
def step_source(gap_m3, wx, wy, ex, ey, storage_rate, inverse_dt, weights, content, previous, k, volume):
    """A step's storage S_k = beta V_k / dt and right-hand side b_k = -(sum_i a_i m_k^{n-i}) / dt into
    ``k`` (groove supply not added), and the gap volume V_k = A_k c + e_x wx_k + e_y wy_k into
    ``volume``, in one pass. ``weights`` (a_0, a_1) are the BDF history weights (a_1 = 0: Euler, then
    ``previous`` is not read); ``storage_rate`` = beta / dt."""
    a0, a1 = weights
    for i in range(volume.size):
        v = gap_m3[i] + ex * wx[i] + ey * wy[i]
        volume[i] = v
        k.storage[i] = v * storage_rate
        old = a0 * content[i] + a1 * previous[i] if a1 != 0.0 else a0 * content[i]
        k.rhs[i] = old * -inverse_dt


@njit(cache=True)
def sweep_start(pressure, fill, full, previous_pressure, previous_fill, extrapolate, p_ref, p, theta):
    """The sweeps' start (scaled pressure ``p``, ``theta``) from a film state: with ``extrapolate``, the
    film extrapolated linearly in time from its last two steps (the partition following the
    extrapolated pressure, theta kept in [0, 1 - 1e-12] where it is cavitated); else the state's own
    unknowns on its partition ``full``."""
    for i in range(p.size):
        if extrapolate:
            extrapolated = 2.0 * pressure[i] - previous_pressure[i]
            if extrapolated > 0.0:
                p[i] = extrapolated / p_ref
                theta[i] = 1.0
            else:
                p[i] = 0.0
                theta[i] = min(min(max(2.0 * fill[i] - previous_fill[i], 0.0), 1.0), 1.0 - 1e-12)
        elif full[i]:
            p[i] = max(pressure[i], 0.0) / p_ref
            theta[i] = 1.0
        else:
            p[i] = 0.0
            theta[i] = min(fill[i], 1.0)
