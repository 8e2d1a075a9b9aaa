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

A bearing with several axial grooves and/or a full circumferential groove (``JournalBearing.more_grooves``,
``circumferential_groove_m``) puts every groove's edges on faces the same way, and all its groove cells form
that one control volume: the grooves hang on one supply manifold whose passages are wide against the film,
so they share one pressure and one fill, and the film alone decides how the supply divides between them
(docs/bearings.md).
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

    @classmethod
    def from_text(cls, text: str, option: str = "--mesh") -> Mesh:
        """The mesh written as ``N_CIRCxN_AXIAL`` (``72x24``); an InputError names ``option`` otherwise."""
        try:
            n_circ, n_axial = (int(part) for part in text.lower().split("x"))
        except ValueError:
            raise InputError(f"{option} must look like 72x24 (N_CIRCxN_AXIAL), got {text!r}") from None
        return cls(n_circ, n_axial)


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


def _segment_faces(segments: list[tuple[float, float, int]]) -> np.ndarray:
    """Faces of a 1-D grid of consecutive segments (start, end, cells), each uniform inside."""
    parts = [np.linspace(start, end, cells + 1) for start, end, cells in segments]
    return np.concatenate([parts[0], *(part[1:] for part in parts[1:])])


def _share_cells(lengths: list[float], total: int) -> list[int]:
    """``total`` cells over segments of ``lengths``, in proportion and at least one each."""
    if len(lengths) == 1:
        return [total]
    exact = np.asarray(lengths) * total / sum(lengths)
    cells = np.maximum(1, np.floor(exact)).astype(int)
    for k in np.argsort(cells - exact):  # the most under-served first
        if cells.sum() >= total:
            break
        cells[k] += 1
    while cells.sum() > total:
        k = int(np.argmax(np.where(cells > 1, cells - exact, -np.inf)))
        cells[k] -= 1
    return [int(c) for c in cells]


def _circumferential_faces(bearing: JournalBearing, n: int) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """psi faces with every axial groove's edges on faces (psi = 0 at the first groove's upstream edge);
    returns (faces, [(i0, i1)] the cell range of each groove in :attr:`JournalBearing.grooves` order)."""
    two_pi = 2.0 * math.pi
    lead = bearing.groove_angle_rad - 0.5 * bearing.groove_span_rad
    pockets = sorted(
        (
            0.0 if k == 0 else (g.angle_rad - 0.5 * g.circumferential_m / bearing.radius_m - lead) % two_pi,
            g.circumferential_m / bearing.radius_m,
            k,
        )
        for k, g in enumerate(bearing.grooves)
    )
    groove_cells = [max(1, round(n * span / two_pi)) for _, span, _ in pockets]
    land_ends = [start for start, _, _ in pockets[1:]] + [two_pi]
    lands = [end - start - span for (start, span, _), end in zip(pockets, land_ends, strict=True)]
    land_cells = _share_cells(lands, n - sum(groove_cells))
    if min(land_cells) < 1 or n - sum(groove_cells) < MIN_CIRCUMFERENTIAL_CELLS // 2:
        raise InputError(f"mesh n_circ={n} leaves too few land cells outside the grooves")
    segments, ranges, i = [], {}, 0
    for (start, span, k), cells, land, end in zip(pockets, groove_cells, land_cells, land_ends, strict=True):
        segments += [(start, start + span, cells), (start + span, end, land)]
        ranges[k] = (i, i + cells)
        i += cells + land
    return _segment_faces(segments), [ranges[k] for k in range(len(pockets))]


def _axial_faces(
    length: float, widths: list[float], n: int
) -> tuple[np.ndarray, dict[float, tuple[int, int]]]:
    """Axial faces with every centred band of ``widths`` (grooves) exactly resolved; returns (faces,
    {width: (j0, j1)} the cell range of each band). The cell count outside the narrowest band is even, so
    the grid is mirror-symmetric about the mid-plane."""
    bands = sorted({w for w in widths if w < length})
    ranges = {w: (0, n) for w in widths if w >= length}
    if not bands:
        return np.linspace(0.0, length, n + 1), ranges
    k = max(1, round(n * bands[0] / length))
    if (n - k) % 2:
        k = k + 1 if k + 1 < n else k - 1
    k = max(1, k)
    edges = [0.5 * (length - w) for w in reversed(bands)]  # lower edges, outermost first
    side = _share_cells([b - a for a, b in zip([0.0, *edges[:-1]], edges, strict=True)], (n - k) // 2)
    lower = list(zip([0.0, *edges[:-1]], edges, side, strict=True))
    uppers = [e + w for e, w in zip(edges, reversed(bands), strict=True)]  # upper edges, outermost first
    upper = list(zip(reversed(uppers), [*reversed(uppers[:-1]), length], reversed(side), strict=True))
    faces = _segment_faces([*lower, (edges[-1], uppers[-1], k), *upper])
    below = np.cumsum(side)
    for w, j0 in zip(reversed(bands), below, strict=True):
        ranges[w] = (int(j0), int(n - j0))
    return faces, ranges


@lru_cache(maxsize=16)
def film_grid(bearing: JournalBearing, mesh: Mesh, half: bool = False) -> FilmGrid:
    """Build (and cache) the grid and the fixed sparsity pattern for ``bearing`` on ``mesh``.

    ``half``: only the cells of z < L/2 of the same mesh (needs an even ``n_axial``), with no flow
    through the mid-plane. A rigid, aligned journal and an axially centred groove make the film
    mirror-symmetric about it, so this half carries exactly half of every flow, force and volume."""
    n, m = mesh.n_circ, mesh.n_axial
    if half and m % 2:
        raise InputError(f"a half (mid-plane symmetric) grid needs an even mesh n_axial, got {m}")
    psi_faces, pockets = _circumferential_faces(bearing, n)
    band = bearing.circumferential_groove_m
    widths = [g.axial_m for g in bearing.grooves] + ([band] if band > 0.0 else [])
    z_faces, bands = _axial_faces(bearing.length_m, widths, m)
    if half:  # every band is centred with an even land on either side (see _axial_faces)
        m //= 2
        z_faces = z_faces[: m + 1]
        bands = {w: (j0, min(j1, m)) for w, (j0, j1) in bands.items()}
    alpha_lead = 0.5 * math.pi + bearing.groove_angle_rad - 0.5 * bearing.groove_span_rad
    alpha_faces = alpha_lead + psi_faces
    alpha_centres = 0.5 * (alpha_faces[:-1] + alpha_faces[1:])

    in_groove = np.zeros((n, m), dtype=bool)
    for groove, (i0, i1) in zip(bearing.grooves, pockets, strict=True):
        j0, j1 = bands[groove.axial_m]
        in_groove[i0:i1, j0:j1] = True
    if band > 0.0:
        j0, j1 = bands[band]
        in_groove[:, j0:j1] = True
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
