"""The plain journal bearing and its feed grooves: geometry and lubricant (SI units).

A bearing is fed through one or more axial grooves (rectangular pockets centred on the mid-plane) and,
optionally, a full circumferential groove at the mid-plane that splits it into two lands. Every groove is
fed from the bearing's one supply line: the film model lumps them into ONE control volume of uniform
pressure and fill (see ``oilwatch.models.bearing.grid`` and docs/bearings.md for why), so the supply
flowrate is the bearing's total and its division between grooves follows from the film's own balance.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..validation import InputError, require_finite, require_in_range, require_non_negative, require_positive

DOWNWARD_LOAD_RAD = math.pi
"""Bearing angle of a load along -y (gravity): the default load direction."""


def load_vector_n(load_n, angle_rad) -> np.ndarray:
    """(..., 2) [N]: forces of magnitude ``load_n`` [N] along the bearing angles ``angle_rad`` [rad] (from the
    top, +y, in the direction of rotation), ``load_n (-sin beta, cos beta)``; scalars or arrays."""
    return np.stack([-load_n * np.sin(angle_rad), load_n * np.cos(angle_rad)], axis=-1)


def load_polar(vector_n) -> tuple[np.ndarray, np.ndarray]:
    """(magnitudes [N], bearing angles in [0, 2 pi) [rad]) of the forces ``vector_n`` (..., 2) [N]: the
    inverse of :func:`load_vector_n`."""
    v = np.asarray(vector_n, dtype=float)
    return np.hypot(v[..., 0], v[..., 1]), np.arctan2(-v[..., 0], v[..., 1]) % (2.0 * math.pi)


@dataclass(frozen=True)
class AxialGroove:
    """One more axial groove: centre angle [rad] (the bearing angle convention of
    ``oilwatch.models.bearing.grid``), circumferential and axial extent [m], centred on the mid-plane."""

    angle_rad: float
    circumferential_m: float
    axial_m: float


@dataclass(frozen=True)
class JournalBearing:
    """A plain cylindrical journal bearing fed through one or more grooves from one supply.

    Attributes
    ----------
    radius_m : journal radius R [m].
    length_m : axial bearing length L [m].
    clearance_m : radial clearance c [m].
    viscosity_pa_s : dynamic viscosity of the oil mu [Pa s].
    groove_angle_rad : angular position of the first groove's centre [rad] (see ``oilwatch.models.bearing``
        for the convention of where 0 lies).
    groove_circumferential_m : the first groove's extent along the circumference [m].
    groove_axial_m : the first groove's extent along the axis [m], centred on the bearing mid-plane.
    more_grooves : the other axial grooves (:class:`AxialGroove`), none for the one-groove bearing.
    circumferential_groove_m : axial width [m] of a full circumferential groove at the mid-plane, 0 for none.
    load_angle_rad : bearing angle [rad] (the grooves' convention) along which the static load pushes the
        journal; pi (the default) is -y, the weight. The grooves and the load are both placed in the
        bearing as installed, and the film sees the grooves where they are relative to the load: this
        angle is part of what a coefficient table is computed for.
    """

    radius_m: float
    length_m: float
    clearance_m: float
    viscosity_pa_s: float
    groove_angle_rad: float
    groove_circumferential_m: float
    groove_axial_m: float
    more_grooves: tuple[AxialGroove, ...] = field(default=())
    circumferential_groove_m: float = 0.0
    load_angle_rad: float = DOWNWARD_LOAD_RAD

    def __post_init__(self) -> None:
        require_positive("radius_m", self.radius_m, "m")
        require_positive("length_m", self.length_m, "m")
        require_positive("clearance_m", self.clearance_m, "m")
        require_positive("viscosity_pa_s", self.viscosity_pa_s, "Pa s")
        if self.clearance_m >= self.radius_m:
            raise InputError("clearance_m must be smaller than radius_m")
        # a table file's ``dataclasses.asdict`` copy gives the extra grooves back as mappings or lists
        object.__setattr__(self, "more_grooves", tuple(_as_groove(g) for g in self.more_grooves))
        for i, groove in enumerate(self.grooves):
            prefix = "groove_" if i == 0 else f"more_grooves[{i - 1}]."
            require_finite(f"{prefix}angle_rad", groove.angle_rad)
            circumferential, axial = f"{prefix}circumferential_m", f"{prefix}axial_m"
            require_positive(circumferential, groove.circumferential_m, "m")
            require_in_range(circumferential, groove.circumferential_m, 0.0, math.pi * self.radius_m, "m")
            require_positive(axial, groove.axial_m, "m")
            require_in_range(axial, groove.axial_m, 0.0, self.length_m, "m")
        require_non_negative("circumferential_groove_m", self.circumferential_groove_m, "m")
        require_in_range(
            "circumferential_groove_m", self.circumferential_groove_m, 0.0, self.length_m, "m", open_high=True
        )
        _check_no_overlap(self.grooves, self.radius_m)
        require_finite("load_angle_rad", self.load_angle_rad)

    @property
    def groove_span_rad(self) -> float:
        """Angular extent of the first groove [rad]."""
        return self.groove_circumferential_m / self.radius_m

    @property
    def grooves(self) -> tuple[AxialGroove, ...]:
        """Every axial groove, the first one first."""
        first = AxialGroove(self.groove_angle_rad, self.groove_circumferential_m, self.groove_axial_m)
        return (first, *self.more_grooves)


def _as_groove(value: AxialGroove | Mapping | Sequence) -> AxialGroove:
    if isinstance(value, AxialGroove):
        return value
    if isinstance(value, Mapping):
        return AxialGroove(**value)
    return AxialGroove(*value)


def _check_no_overlap(grooves: tuple[AxialGroove, ...], radius_m: float) -> None:
    """Axial grooves must not overlap around the circumference (each is a pocket between two lands)."""
    if len(grooves) < 2:
        return
    spans = sorted(
        (
            (g.angle_rad - 0.5 * g.circumferential_m / radius_m) % (2.0 * math.pi),
            g.circumferential_m / radius_m,
            i,
        )
        for i, g in enumerate(grooves)
    )
    following = [*spans[1:], (spans[0][0] + 2.0 * math.pi, 0.0, spans[0][2])]
    for (start, span, i), (next_start, _, j) in zip(spans, following, strict=True):
        if start + span >= next_start:
            raise InputError(
                f"axial grooves {i} and {j} overlap around the circumference: give them distinct angles "
                "at least half their widths apart"
            )
