"""Finite-volume coefficients of the p-theta Reynolds equation (paper Eq. 1) on a :class:`FilmGrid`.

Every control volume k balances its volume flow (Ausas, Jai & Buscaglia, J. Tribol. 131, 031702,
2009; Giacopini et al., J. Tribol. 132, 041702, 2010):

    sum_j Ap[k, j] p_j  +  sum_j At[k, j] theta_j  +  squeeze_k  =  source_k            [m^3/s]

* ``Ap`` is the Poiseuille part, h^3 / (12 mu) dp/dn integrated over each face, with h^3 at the face,
  the pressure gradient from centre to centre (from the groove's edge for the lumped groove) and
  ambient pressure (0) half a cell beyond each bearing end;
* ``At`` is the Couette part, (U/2) h theta through each circumferential face, with h evaluated
  exactly at the face and theta taken upwind (the shaft drags oil in +psi), which keeps the
  full-film scheme second-order accurate and the cavitated one stable;
* ``squeeze_k = theta_k * integral(dh/dt dA)`` of the volume, with dh/dt = -(v_x cos a + v_y sin a)
  for a journal moving at (v_x, v_y); see :mod:`oilwatch.models.bearing.film` for where it is applied.

The same cell integrals give the film force: F = sum_k p_k w_k with w = (wx, wy) per node, and
integral(dh/dt dA) = v_x wx + v_y wy, so pressure and squeeze use one quadrature (this is what makes
the full-film damping matrix symmetric).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .grid import FilmGrid


@dataclass(frozen=True, eq=False)
class FilmOperator:
    """Coefficient arrays of one film state (position, velocity, speed) on ``grid.pattern``.

    Attributes: ap_data, at_data (nnz,) CSR data of Ap [m^3/(s Pa)] and At [m^3/s];
    squeeze_m3_s (n_nodes,) integral of dh/dt over each volume [m^3/s]; wx, wy (n_nodes,) force
    weights [m^2] (F = sum p w); h_min_m smallest film thickness [m]; couette_scale_m3_s the
    Couette flow U c L / 2 used to scale residuals [m^3/s]; end_nodes, end_conductance (n_ef,)
    the land volumes on the bearing ends and their conductance to ambient [m^3/(s Pa)];
    velocity_m_s, omega_rad_s the journal velocity [m/s] and spin speed [rad/s] it was built for.
    """

    grid: FilmGrid
    ap_data: np.ndarray
    at_data: np.ndarray
    squeeze_m3_s: np.ndarray
    wx: np.ndarray
    wy: np.ndarray
    h_min_m: float
    couette_scale_m3_s: float
    end_nodes: np.ndarray
    end_conductance: np.ndarray
    velocity_m_s: tuple[float, float]
    omega_rad_s: float


def film_thickness(grid: FilmGrid, ex: float, ey: float, alpha: np.ndarray) -> np.ndarray:
    """h(alpha) = c - e_x cos(alpha) - e_y sin(alpha) [m] of a journal displaced by (ex, ey) [m]."""
    return grid.bearing.clearance_m - ex * np.cos(alpha) - ey * np.sin(alpha)


def force_weights(grid: FilmGrid) -> tuple[np.ndarray, np.ndarray]:
    """Per-node weights (wx, wy) [m^2]: F = sum_k p_k (wx_k, wy_k) for the force on the journal."""
    r = grid.bearing.radius_m
    af = grid.alpha_faces_rad
    dz = grid.dz
    cx = -r * (np.sin(af[1:]) - np.sin(af[:-1]))[:, None] * dz[None, :]
    cy = r * (np.cos(af[1:]) - np.cos(af[:-1]))[:, None] * dz[None, :]
    nodes = grid.node_of_cell.ravel()
    wx = np.bincount(nodes, weights=cx.ravel(), minlength=grid.n_nodes)
    wy = np.bincount(nodes, weights=cy.ravel(), minlength=grid.n_nodes)
    return wx, wy


def film_operator(
    grid: FilmGrid,
    eccentricity_m: tuple[float, float],
    velocity_m_s: tuple[float, float],
    omega_rad_s: float,
) -> FilmOperator:
    """Assemble the coefficients for a journal at ``eccentricity_m`` moving at ``velocity_m_s``."""
    bearing = grid.bearing
    ex, ey = eccentricity_m
    mu12 = 12.0 * bearing.viscosity_pa_s
    r = bearing.radius_m
    dpsi = grid.dpsi
    dz = grid.dz
    slots = grid.slots
    nnz = grid.pattern.nnz
    n_nodes = grid.n_nodes

    h_faces = film_thickness(grid, ex, ey, grid.alpha_faces_rad)
    h_centres = film_thickness(grid, ex, ey, grid.alpha_centres_rad)
    h_min = float(min(h_faces.min(), h_centres.min()))

    cf = grid.circ_faces
    hf = h_faces[cf[:, 0]]
    g_circ = hf**3 / mu12 * dz[cf[:, 1]] / grid.circ_dist
    c_circ = 0.5 * omega_rad_s * r * hf * dz[cf[:, 1]]
    af = grid.axial_faces
    hc = h_centres[af[:, 0]]
    g_axial = hc**3 / mu12 * r * dpsi[af[:, 0]] / grid.axial_dist
    ef = grid.end_faces
    he = h_centres[ef[:, 0]]
    g_end = he**3 / mu12 * r * dpsi[ef[:, 0]] / grid.end_dist

    end_nodes = grid.node_of_cell[ef[:, 0], ef[:, 1]]
    up, down = cf[:, 2], cf[:, 3]
    lo, hi = af[:, 1], af[:, 2]
    diag_g = (
        np.bincount(up, weights=g_circ, minlength=n_nodes)
        + np.bincount(down, weights=g_circ, minlength=n_nodes)
        + np.bincount(lo, weights=g_axial, minlength=n_nodes)
        + np.bincount(hi, weights=g_axial, minlength=n_nodes)
        + np.bincount(end_nodes, weights=g_end, minlength=n_nodes)
    )
    ap = np.bincount(slots["diag"], weights=diag_g, minlength=nnz)
    ap -= np.bincount(slots["circ_ud"], weights=g_circ, minlength=nnz)
    ap -= np.bincount(slots["circ_du"], weights=g_circ, minlength=nnz)
    ap -= np.bincount(slots["axial_ud"], weights=g_axial, minlength=nnz)
    ap -= np.bincount(slots["axial_du"], weights=g_axial, minlength=nnz)

    at = np.bincount(slots["diag"], weights=np.bincount(up, weights=c_circ, minlength=n_nodes), minlength=nnz)
    at -= np.bincount(slots["circ_du"], weights=c_circ, minlength=nnz)

    wx, wy = force_weights(grid)
    vx, vy = velocity_m_s
    return FilmOperator(
        grid=grid,
        ap_data=ap,
        at_data=at,
        squeeze_m3_s=vx * wx + vy * wy,
        wx=wx,
        wy=wy,
        h_min_m=h_min,
        couette_scale_m3_s=0.5 * omega_rad_s * r * bearing.clearance_m * bearing.length_m,
        end_nodes=end_nodes,
        end_conductance=g_end,
        velocity_m_s=(float(vx), float(vy)),
        omega_rad_s=float(omega_rad_s),
    )
