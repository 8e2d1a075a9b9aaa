"""Timoshenko shaft element with 4 dof per node [V (x), W (y), B (about x), Gamma (about y)].

Reference: M. I. Friswell, J. E. T. Penny, S. D. Garvey, A. W. Lees, "Dynamics of Rotating
Machines", Cambridge University Press, 2010, ch. 5 (the Timoshenko element with
the interdependent interpolation of Przemieniecki / Nelson). Element dofs are
[V1, W1, B1, Gamma1, V2, W2, B2, Gamma2]; the shaft axis is z and spins about +z.

Sign convention (right-handed x, y, z): a rotation Gamma about +y tilts the axis towards +x, so
Gamma = dV/dz in the Euler-Bernoulli limit; a rotation B about +x tilts it towards -y, so
B = -dW/dz. Each bending plane is therefore the textbook planar beam with dofs (w, phi = dw/dz):
x-z plane (V, Gamma), y-z plane (W, -B). The 3-D matrices are assembled from the planar ones by
that mapping, which keeps the formulas in one place.

All functions are vectorized over elements: lengths and diameters of shape (n,), results (n, 8, 8)
or (n, 8), SI units.
"""

from __future__ import annotations

import numpy as np

from ..machine_sections import Material

# Maps element dofs to the planar dofs (w1, phi1, w2, phi2) of each bending plane.
_PLANE_X = np.zeros((4, 8))
_PLANE_X[[0, 1, 2, 3], [0, 3, 4, 7]] = 1.0
_PLANE_Y = np.zeros((4, 8))
_PLANE_Y[[0, 1, 2, 3], [1, 2, 5, 6]] = [1.0, -1.0, 1.0, -1.0]


def cowper_shear_coefficient(poisson_ratio: float) -> float:
    """Cowper's (1966) shear coefficient of a solid circular section, 6 (1 + nu) / (7 + 6 nu)."""
    return 6.0 * (1.0 + poisson_ratio) / (7.0 + 6.0 * poisson_ratio)


def section_properties(diameters_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Area A [m^2] and second moment of area I [m^4] of solid circular sections, shape (n,)."""
    d = np.asarray(diameters_m, dtype=float)
    return np.pi * d**2 / 4.0, np.pi * d**4 / 64.0


def shear_parameter(lengths_m: np.ndarray, diameters_m: np.ndarray, material: Material) -> np.ndarray:
    """Phi = 12 E I / (kappa G A L^2) [-], the shear-flexibility ratio of each element, shape (n,)."""
    area, inertia = section_properties(diameters_m)
    kappa = cowper_shear_coefficient(material.poisson_ratio)
    length = np.asarray(lengths_m, dtype=float)
    return (
        12.0 * material.youngs_modulus_pa * inertia / (kappa * material.shear_modulus_pa * area * length**2)
    )


def _planar_to_3d(planar: np.ndarray) -> np.ndarray:
    """Put a planar (n, 4, 4) matrix into both bending planes: (n, 8, 8)."""
    return np.einsum("ai,nab,bj->nij", _PLANE_X, planar, _PLANE_X) + np.einsum(
        "ai,nab,bj->nij", _PLANE_Y, planar, _PLANE_Y
    )


def _symmetric(upper: list[list[np.ndarray | float]], n: int) -> np.ndarray:
    out = np.zeros((n, 4, 4))
    for i in range(4):
        for j in range(i, 4):
            out[:, i, j] = upper[i][j - i]
            out[:, j, i] = out[:, i, j]
    return out


def planar_stiffness(lengths_m, diameters_m, material: Material) -> np.ndarray:
    """Planar bending stiffness with shear, dofs (w1, phi1, w2, phi2): (n, 4, 4) [N/m, N, N m].

    Friswell et al. (2010) ch. 5; Przemieniecki (1968): EI / ((1 + Phi) L^3) times the matrix
    with (4 + Phi) L^2 and (2 - Phi) L^2 on the rotation terms.
    """
    length = np.asarray(lengths_m, dtype=float)
    _, inertia = section_properties(diameters_m)
    phi = shear_parameter(length, diameters_m, material)
    L = length
    k = _symmetric(
        [
            [12.0, 6.0 * L, -12.0, 6.0 * L],
            [(4.0 + phi) * L**2, -6.0 * L, (2.0 - phi) * L**2],
            [12.0, -6.0 * L],
            [(4.0 + phi) * L**2],
        ],
        L.size,
    )
    return k * (material.youngs_modulus_pa * inertia / ((1.0 + phi) * L**3))[:, None, None]


def planar_translational_mass(lengths_m, diameters_m, material: Material) -> np.ndarray:
    """Planar consistent translational mass of the Timoshenko element: (n, 4, 4) [kg, kg m, kg m^2].

    Friswell et al. (2010) ch. 5 (reduces to rho A L / 420 [156, 22L, 54, -13L, ...] at Phi=0).
    """
    L = np.asarray(lengths_m, dtype=float)
    area, _ = section_properties(diameters_m)
    f = shear_parameter(L, diameters_m, material)
    m1 = 312.0 + 588.0 * f + 280.0 * f**2
    m2 = (44.0 + 77.0 * f + 35.0 * f**2) * L
    m3 = 108.0 + 252.0 * f + 140.0 * f**2
    m4 = (26.0 + 63.0 * f + 35.0 * f**2) * L
    m5 = (8.0 + 14.0 * f + 7.0 * f**2) * L**2
    m6 = (6.0 + 14.0 * f + 7.0 * f**2) * L**2
    m = _symmetric([[m1, m2, m3, -m4], [m5, m4, -m6], [m1, -m2], [m5]], L.size)
    scale = material.density_kg_m3 * area * L / (840.0 * (1.0 + f) ** 2)
    return m * scale[:, None, None]


def planar_rotary_inertia(lengths_m, diameters_m, material: Material) -> np.ndarray:
    """Planar rotary (diametral) inertia of the Timoshenko element: (n, 4, 4).

    Friswell et al. (2010) ch. 5: rho I / (30 (1 + Phi)^2 L) times the matrix with 36,
    (3 - 15 Phi) L, (4 + 5 Phi + 10 Phi^2) L^2 and (-1 - 5 Phi + 5 Phi^2) L^2.
    """
    L = np.asarray(lengths_m, dtype=float)
    _, inertia = section_properties(diameters_m)
    f = shear_parameter(L, diameters_m, material)
    a = (3.0 - 15.0 * f) * L
    b = (4.0 + 5.0 * f + 10.0 * f**2) * L**2
    c = (-1.0 - 5.0 * f + 5.0 * f**2) * L**2
    m = _symmetric([[36.0, a, -36.0, a], [b, -a, c], [36.0, -a], [b]], L.size)
    scale = material.density_kg_m3 * inertia / (30.0 * (1.0 + f) ** 2 * L)
    return m * scale[:, None, None]


def element_stiffness(lengths_m, diameters_m, material: Material) -> np.ndarray:
    """Bending stiffness with shear deformation of each element, (n, 8, 8), symmetric PSD."""
    return _planar_to_3d(planar_stiffness(lengths_m, diameters_m, material))


def element_mass(lengths_m, diameters_m, material: Material) -> np.ndarray:
    """Mass matrix of each element (translational + rotary inertia), (n, 8, 8), symmetric PD."""
    planar = planar_translational_mass(lengths_m, diameters_m, material) + planar_rotary_inertia(
        lengths_m, diameters_m, material
    )
    return _planar_to_3d(planar)


def element_gyroscopic(lengths_m, diameters_m, material: Material) -> np.ndarray:
    """Gyroscopic matrix per unit spin speed of each element, (n, 8, 8), skew-symmetric [kg m^2].

    The polar inertia per unit length is 2 rho I, so with the rotary-inertia matrix R of one plane
    G = 2 (T_x^T R T_y - T_y^T R T_x) (cf. Friswell et al. 2010, ch. 5): the B row carries
    +Omega I_p dGamma/dt and the Gamma row -Omega I_p dB/dt, as for a disc.
    """
    rotary = planar_rotary_inertia(lengths_m, diameters_m, material)
    coupling = np.einsum("ai,nab,bj->nij", _PLANE_X, rotary, _PLANE_Y)
    return 2.0 * (coupling - np.transpose(coupling, (0, 2, 1)))


def element_gravity_load(lengths_m, diameters_m, material: Material, gravity_m_s2: float):
    """Consistent nodal load of the shaft's own weight (along -y), (n, 8) [N, N m].

    The interdependent-interpolation element integrates a uniform load q to the same nodal loads
    as the Hermite beam, (qL/2, qL^2/12, qL/2, -qL^2/12) in the y-z plane, which are exact at the
    nodes for Timoshenko beams.
    """
    L = np.asarray(lengths_m, dtype=float)
    area, _ = section_properties(diameters_m)
    q = -material.density_kg_m3 * area * gravity_m_s2
    planar = np.stack([q * L / 2.0, q * L**2 / 12.0, q * L / 2.0, -q * L**2 / 12.0], axis=1)
    return planar @ _PLANE_Y
