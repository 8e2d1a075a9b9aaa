"""Rigid annular disc on a shaft node: mass, diametral and polar inertia, gyroscopic coupling.

Reference: Friswell et al., "Dynamics of Rotating Machines" (2010), ch. 5 (rigid
discs). Nodal dofs [V (x), W (y), B (about x), Gamma (about y)]; spin about +z.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RigidDisc:
    """Inertia of a rigid disc: mass_kg [kg], diametral and polar moments of inertia [kg m^2]."""

    mass_kg: float
    diametral_inertia_kg_m2: float
    polar_inertia_kg_m2: float

    @classmethod
    def annulus(
        cls, density_kg_m3: float, width_m: float, outer_diameter_m: float, bore_diameter_m: float
    ) -> RigidDisc:
        """An annular disc of uniform density (width along the axis, diameters in metres).

        m = rho pi (Do^2 - Di^2) h / 4, Ip = m (Do^2 + Di^2) / 8, Id = Ip / 2 + m h^2 / 12.
        """
        mass = density_kg_m3 * math.pi * (outer_diameter_m**2 - bore_diameter_m**2) * width_m / 4.0
        polar = mass * (outer_diameter_m**2 + bore_diameter_m**2) / 8.0
        diametral = polar / 2.0 + mass * width_m**2 / 12.0
        return cls(mass, diametral, polar)

    def mass_matrix(self) -> np.ndarray:
        """Nodal mass matrix (4, 4): diag(m, m, Id, Id)."""
        m, i_d = self.mass_kg, self.diametral_inertia_kg_m2
        return np.diag([m, m, i_d, i_d])

    def gyroscopic_matrix(self) -> np.ndarray:
        """Nodal gyroscopic matrix per unit spin speed (4, 4), skew: G[B, Gamma] = +Ip.

        From the angular momentum Ip Omega along the tilted axis (Gamma, -B, 1): the moment about x
        needs Id B'' + Omega Ip Gamma', the moment about y Id Gamma'' - Omega Ip B'.
        """
        g = np.zeros((4, 4))
        g[2, 3] = self.polar_inertia_kg_m2
        g[3, 2] = -self.polar_inertia_kg_m2
        return g
