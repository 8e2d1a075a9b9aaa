"""Flexible bearing pedestals: a mass on a spring and damper under each bearing, in x and y.

A real bearing housing sits on a pedestal and a foundation that are not rigid. The simplest model that
gives the support its own resonance is one lumped mass per bearing, isotropic in x and y, on a spring and a
viscous damper to ground; the film then acts between the journal and that mass, and the proximity probes,
mounted in the housing, read the journal relative to it (Vance, Zeidan & Murphy, "Machinery Vibration and
Rotordynamics" (2010), sec. 5.6; API 684, support stiffness). Coordinates of the pedestal masses are
measured from their rest under their own weight (their weight is carried by the spring and does not load
the film).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..validation import require_non_negative, require_positive


@dataclass(frozen=True)
class Pedestals:
    """The same pedestal under every bearing: modal mass [kg], stiffness [N/m] and damping [N s/m] to
    ground, each in x and in y."""

    mass_kg: float
    stiffness_n_m: float
    damping_n_s_m: float = 0.0

    def __post_init__(self) -> None:
        require_positive("pedestal mass", self.mass_kg, "kg")
        require_positive("pedestal stiffness", self.stiffness_n_m, "N/m")
        require_non_negative("pedestal damping", self.damping_n_s_m, "N s/m")

    @property
    def natural_frequency_hz(self) -> float:
        """sqrt(k / m) / 2 pi: the pedestal's own resonance with the journal held still [Hz]."""
        return math.sqrt(self.stiffness_n_m / self.mass_kg) / (2.0 * math.pi)

    @property
    def damping_ratio(self) -> float:
        """c / (2 sqrt(k m)) [-]."""
        return self.damping_n_s_m / (2.0 * math.sqrt(self.stiffness_n_m * self.mass_kg))

    def matrices(self, n_bearings: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(M, C, K) of the pedestal coordinates (x1, y1, x2, y2, ...) (2 n_bearings square, diagonal)."""
        eye = np.eye(2 * n_bearings)
        return self.mass_kg * eye, self.damping_n_s_m * eye, self.stiffness_n_m * eye
