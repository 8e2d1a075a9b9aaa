"""The finite-volume grid of the unwrapped film and its fixed connectivity (shared by both solvers).

Angle convention (documented once, used everywhere in ``oilwatch.models.bearing``)
-------------------------------------------------------------------------
x is horizontal, y vertical up, the static load pushes the journal along -y and the shaft spins about
+z, from +x towards +y. A point of the bearing bore is located by its polar angle ``alpha`` measured
from +x towards +y. The *bearing angle* of Table 3 ("groove at 0 deg") is measured from the TOP of the
bearing (+y, opposite the load) in the direction of rotation: ``alpha = 90 deg + bearing_angle``.
The groove at 0 deg therefore sits at the top, in the unloaded half, feeding the oil that the journal
carries down into the loaded half. This is the only placement that reproduces the paper's flows
(REFERENCE.md: 601.9 ml/min at 0.5 bar and q_t = 543.8 ml/min against the paper's 596.3 and 546; a
groove on the load line gives no equilibrium at all, a horizontal one 3-40 % less flow).

Film thickness of a rigid, aligned journal displaced by (e_x, e_y):
``h(alpha) = c - e_x cos(alpha) - e_y sin(alpha)``.

Grid
----
The film is unwrapped along psi in [0, 2 pi), psi = 0 at the groove's upstream edge, and along z in
[0, L]. The grid is a tensor product of two non-uniform 1-D grids chosen so that the groove's edges
fall exactly on cell faces (groove cells uniform inside the groove, land cells uniform outside): the
groove's boundary fluxes, which set the supply flow, are then not spoiled by a staircase groove.
All groove cells form ONE lumped control volume (the groove is deep: its pressure and fill are
uniform); the land cells are the other control volumes. The groove is closed at its axial ends.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import scipy.sparse as sp

from ..validation import InputError
from .geometry import JournalBearing

MIN_CIRCUMFERENTIAL_CELLS = 24
MIN_AXIAL_CELLS = 6


@dataclass(frozen=True)
class Mesh:
    """Number of finite volumes around the circumference (``n_circ``) and along the axis (``n_axial``)."""

    n_circ: int = 100
    n_axial: int = 30

    def __post_init__(self) -> None:
        for name, value, low in (
            ("n_circ", self.n_circ, MIN_CIRCUMFERENTIAL_CELLS),
            ("n_axial", self.n_axial, MIN_AXIAL_CELLS),
        ):
            if not isinstance(value, int | np.integer) or isinstance(value, bool):
                raise InputError(f"mesh {name} must be an integer, got {value!r}")
            if value < low:
                raise InputError(f"mesh {name} must be >= {low} (mesh too coarse), got {value}")


PRODUCTION_MESH = Mesh(240, 72)
"""Mesh of the committed coefficient tables. Against a mesh twice as fine (480 x 144), at every
flowrate of the 7-point table (tests/test_bearing_coefficients.py): equilibria within 0.2 %, K and C
within 1 % of the matrix's largest entry (normwise: at most 0.95 % for K, 0.8 % for C). Entry by
entry the stiffness differs by up to 2.6 % (Kyy at 117 % of q_t) and the damping by up to 1.4 %
(Cxy): the held-partition stiffness is the exact derivative of the discrete film, whose cavitation
boundaries advance cell by cell, so it carries a mesh-scale ripple of 1-2 % that does not shrink
steadily with the mesh (200 x 60 vs 400 x 120: up to 1.7 % per entry; the damping converges
first-order, 1.2 % normwise at 50 % of q_t on 200 x 60, hence this mesh)."""


@dataclass(frozen=True, eq=False)
class FilmGrid:
    """Geometry and connectivity of the film grid for one bearing and mesh (see module docstring).

    Cell arrays have shape (n_circ, n_axial); node arrays have shape (n_nodes,): the land cells first
    (circumferential-major order), then the groove node (index ``groove_node``).

    Attributes
    ----------
    psi_faces_rad : (n_circ + 1,) circumferential face positions [rad], psi = 0 at the groove's
        upstream edge.
    z_faces_m : (n_axial + 1,) axial face positions [m].
    alpha_faces_rad, alpha_centres_rad : absolute polar angles of faces and cell centres [rad].
    in_groove : (n_circ, n_axial) bool, cells covered by the groove.
    node_of_cell : (n_circ, n_axial) int, control volume of each cell.
    circ_faces : (n_cf, 4) int rows (face index in psi, axial index j, upstream node, downstream node)
        of circumferential faces between different control volumes; ``circ_half`` (n_cf,) the
        centre-to-centre distance [m] used for the pressure gradient.
    axial_faces : (n_af, 3) int rows (circ index i, node below, node above); ``axial_dist`` [m].
    end_faces : (n_ef, 2) int rows (circ index i, axial index j) of land cells on a bearing end;
        ``end_dist`` [m] (half a cell).
    """

    bearing: JournalBearing
    mesh: Mesh
    psi_faces_rad: np.ndarray
    z_faces_m: np.ndarray
    alpha_faces_rad: np.ndarray
    alpha_centres_rad: np.ndarray
    in_groove: np.ndarray
    node_of_cell: np.ndarray
    n_nodes: int
    groove_node: int
    circ_faces: np.ndarray
    circ_dist: np.ndarray
    axial_faces: np.ndarray
    axial_dist: np.ndarray
    end_faces: np.ndarray
    end_dist: np.ndarray
    pattern: sp.csr_matrix
    slots: dict
    half: bool = False
    """True: the grid covers z in [0, L/2] only, closed (a symmetry plane) at z = L/2 (:func:`film_grid`)."""

    @property
    def dpsi(self) -> np.ndarray:
        """(n_circ,) cell widths [rad]."""
        return np.diff(self.psi_faces_rad)

    @property
    def dz(self) -> np.ndarray:
        """(n_axial,) cell lengths [m]."""
        return np.diff(self.z_faces_m)


def _split_faces(total: float, part: float, n_total: int, n_part: int, start: float) -> np.ndarray:
    """Faces of a 1-D grid: ``n_part`` uniform cells over ``part`` then the rest uniform."""
    first = np.linspace(start, start + part, n_part + 1)
    second = np.linspace(start + part, start + total, n_total - n_part + 1)
    return np.concatenate([first, second[1:]])


def _axial_faces(length: float, groove: float, n: int) -> tuple[np.ndarray, int, int]:
    """Axial faces with the groove centred and exactly resolved; returns (faces, j0, j1)."""
    if groove >= length:
        return np.linspace(0.0, length, n + 1), 0, n
    k = max(1, round(n * groove / length))
    if (n - k) % 2:
        k = k + 1 if k + 1 < n else k - 1
    k = max(1, k)
    land = (n - k) // 2
    z0 = 0.5 * (length - groove)
    faces = np.concatenate(
        [
            np.linspace(0.0, z0, land + 1),
            np.linspace(z0, z0 + groove, k + 1)[1:],
            np.linspace(z0 + groove, length, land + 1)[1:],
        ]
    )
    return faces, land, land + k


@lru_cache(maxsize=16)
def film_grid(bearing: JournalBearing, mesh: Mesh, half: bool = False) -> FilmGrid:
    """Build (and cache) the grid and the fixed sparsity pattern for ``bearing`` on ``mesh``.

    ``half``: only the cells of z < L/2 of the same mesh (needs an even ``n_axial``), with no flow
    through the mid-plane. A rigid, aligned journal and an axially centred groove make the film
    mirror-symmetric about it, so this half carries exactly half of every flow, force and volume."""
    n, m = mesh.n_circ, mesh.n_axial
    if half and m % 2:
        raise InputError(f"a half (mid-plane symmetric) grid needs an even mesh n_axial, got {m}")
    span = bearing.groove_span_rad
    k_circ = max(1, round(n * span / (2.0 * math.pi)))
    if n - k_circ < MIN_CIRCUMFERENTIAL_CELLS // 2:
        raise InputError(f"mesh n_circ={n} leaves too few land cells outside the groove")
    psi_faces = _split_faces(2.0 * math.pi, span, n, k_circ, 0.0)
    z_faces, j0, j1 = _axial_faces(bearing.length_m, bearing.groove_axial_m, m)
    if half:  # the groove is centred with an even land on either side (see _axial_faces)
        m //= 2
        z_faces, j1 = z_faces[: m + 1], min(j1, m)
    alpha_lead = 0.5 * math.pi + bearing.groove_angle_rad - 0.5 * span
    alpha_faces = alpha_lead + psi_faces
    alpha_centres = 0.5 * (alpha_faces[:-1] + alpha_faces[1:])

    in_groove = np.zeros((n, m), dtype=bool)
    in_groove[:k_circ, j0:j1] = True
    node_of_cell = np.full((n, m), -1, dtype=np.int64)
    land = ~in_groove
    n_land = int(land.sum())
    node_of_cell[land] = np.arange(n_land)
    node_of_cell[in_groove] = n_land
    n_nodes = n_land + 1

    radius = bearing.radius_m
    dpsi = np.diff(psi_faces)
    dz = np.diff(z_faces)

    # Circumferential faces: face f (1..n, periodic) lies between cell f-1 (upstream) and cell f.
    up_i = np.arange(n)
    down_i = (up_i + 1) % n
    face_i = down_i  # index into psi_faces modulo n: face between up_i and down_i
    fi, jj = np.meshgrid(face_i, np.arange(m), indexing="ij")
    ui, _ = np.meshgrid(up_i, np.arange(m), indexing="ij")
    di, _ = np.meshgrid(down_i, np.arange(m), indexing="ij")
    a = node_of_cell[ui, jj]
    b = node_of_cell[di, jj]
    keep = a != b
    dist = 0.5 * (dpsi[ui] * ~in_groove[ui, jj] + dpsi[di] * ~in_groove[di, jj]) * radius
    circ_faces = np.stack([fi[keep], jj[keep], a[keep], b[keep]], axis=1)
    circ_dist = dist[keep]

    # Axial faces between cell (i, j) and (i, j + 1).
    ai, aj = np.meshgrid(np.arange(n), np.arange(m - 1), indexing="ij")
    lo = node_of_cell[ai, aj]
    hi = node_of_cell[ai, aj + 1]
    keep = lo != hi
    adist = 0.5 * (dz[aj] * ~in_groove[ai, aj] + dz[aj + 1] * ~in_groove[ai, aj + 1])
    axial_faces = np.stack([ai[keep], lo[keep], hi[keep]], axis=1)
    axial_dist = adist[keep]

    # Bearing ends (ambient pressure); the groove is closed at its axial ends.
    ends = [(i, j) for j in ((0,) if half else (0, m - 1)) for i in range(n) if not in_groove[i, j]]
    end_faces = np.array(ends, dtype=np.int64).reshape(-1, 2)
    end_dist = 0.5 * dz[end_faces[:, 1]]

    pattern, slots = _pattern(n_nodes, circ_faces[:, 2:4], axial_faces[:, 1:3], node_of_cell)
    return FilmGrid(
        bearing=bearing,
        mesh=mesh,
        psi_faces_rad=psi_faces,
        z_faces_m=z_faces,
        alpha_faces_rad=alpha_faces,
        alpha_centres_rad=alpha_centres,
        in_groove=in_groove,
        node_of_cell=node_of_cell,
        n_nodes=n_nodes,
        groove_node=n_land,
        circ_faces=circ_faces,
        circ_dist=circ_dist,
        axial_faces=axial_faces,
        axial_dist=axial_dist,
        end_faces=end_faces,
        end_dist=end_dist,
        pattern=pattern,
        slots=slots,
        half=half,
    )


def _pattern(n_nodes: int, circ_pairs: np.ndarray, axial_pairs: np.ndarray, node_of_cell):
    """CSR sparsity pattern of the node graph and the data slot of every (row, col) entry we add."""
    pairs = np.concatenate([circ_pairs, axial_pairs])
    rows = np.concatenate([pairs[:, 0], pairs[:, 1], np.arange(n_nodes)])
    cols = np.concatenate([pairs[:, 1], pairs[:, 0], np.arange(n_nodes)])
    pattern = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(n_nodes, n_nodes), dtype=float)
    pattern.sum_duplicates()
    pattern.sort_indices()
    lookup = sp.csr_matrix(
        (np.arange(pattern.nnz, dtype=float) + 1.0, pattern.indices, pattern.indptr),
        shape=pattern.shape,
    )

    def slot(r: np.ndarray, c: np.ndarray) -> np.ndarray:
        return np.asarray(lookup[r, c]).ravel().astype(np.int64) - 1

    cu, cd = circ_pairs[:, 0], circ_pairs[:, 1]
    au, ad = axial_pairs[:, 0], axial_pairs[:, 1]
    diag = slot(np.arange(n_nodes), np.arange(n_nodes))
    slots = {
        "diag": diag,
        "circ_ud": slot(cu, cd),
        "circ_du": slot(cd, cu),
        "axial_ud": slot(au, ad),
        "axial_du": slot(ad, au),
        "columns": pattern.indices.astype(np.int64),
        "rows": np.repeat(np.arange(n_nodes), np.diff(pattern.indptr)),
    }
    return pattern, slots
