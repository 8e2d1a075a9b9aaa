"""The plain journal bearing with one axial feed groove: geometry and lubricant (SI units)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..validation import InputError, require_in_range, require_positive


@dataclass(frozen=True)
class JournalBearing:
    """A plain cylindrical journal bearing fed through one rectangular groove.

    Attributes
    ----------
    radius_m : journal radius R [m].
    length_m : axial bearing length L [m].
    clearance_m : radial clearance c [m].
    viscosity_pa_s : dynamic viscosity of the oil mu [Pa s].
    groove_angle_rad : angular position of the groove centre [rad] (see ``oilwatch.models.bearing`` for the
        convention of where 0 lies).
    groove_circumferential_m : groove extent along the circumference [m].
    groove_axial_m : groove extent along the axis [m], centred on the bearing mid-plane.
    """

    radius_m: float
    length_m: float
    clearance_m: float
    viscosity_pa_s: float
    groove_angle_rad: float
    groove_circumferential_m: float
    groove_axial_m: float

    def __post_init__(self) -> None:
        require_positive("radius_m", self.radius_m, "m")
        require_positive("length_m", self.length_m, "m")
        require_positive("clearance_m", self.clearance_m, "m")
        require_positive("viscosity_pa_s", self.viscosity_pa_s, "Pa s")
        require_positive("groove_circumferential_m", self.groove_circumferential_m, "m")
        require_in_range("groove_axial_m", self.groove_axial_m, 0.0, self.length_m, "m")
        if self.groove_axial_m <= 0.0:
            raise InputError(f"groove_axial_m must be > 0 m, got {self.groove_axial_m:g}")
        require_in_range(
            "groove_circumferential_m",
            self.groove_circumferential_m,
            0.0,
            math.pi * self.radius_m,
            "m",
        )
        if self.clearance_m >= self.radius_m:
            raise InputError("clearance_m must be smaller than radius_m")

    @property
    def groove_span_rad(self) -> float:
        """Angular extent of the groove [rad]."""
        return self.groove_circumferential_m / self.radius_m
