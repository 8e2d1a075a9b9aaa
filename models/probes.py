"""The machine file's ``[probes]`` section: how the proximity probes are mounted and what is known of them.

Read from :attr:`models.machine.Machine.raw` (the section is optional; every key has a default)::

    [probes]
    angle_deg = 0.0                  # mounting angle of each bearing's X/Y pair from the model's axes,
                                     # counter-clockwise from +x (45: API 670, either side of the top)
    offset_prior_std_um = 25.0       # std of each probe's zero offset before any baseline
    offset_random_walk_um_sqrt_s = 0.2   # drift of the offsets [um / sqrt(s)]

The offsets' prior: the bearing centre is known only from the cold-rest position and a clearance with a
tolerance, so zero offsets of 10-25 um are ordinary.
"""

from __future__ import annotations

from dataclasses import dataclass

from .machine import Machine
from .validation import InputError, require_in_range

DEFAULTS = {"angle_deg": 0.0, "offset_prior_std_um": 25.0, "offset_random_walk_um_sqrt_s": 0.2}


@dataclass(frozen=True)
class Probes:
    """SI values of the ``[probes]`` section: angle_deg [deg], offset_prior_std_m [m],
    offset_random_walk_m_sqrt_s [m / sqrt(s)]."""

    angle_deg: float
    offset_prior_std_m: float
    offset_random_walk_m_sqrt_s: float


def read_probes(machine: Machine) -> Probes:
    """The machine's probe section with its defaults (one-line InputError naming a bad key)."""
    section = machine.raw.get("probes", {})
    if not isinstance(section, dict):
        raise InputError("[probes] must be a table")
    # the section is shared with the recorded-data reader (layout, columns): only these keys are read here
    values = {key: section.get(key, default) for key, default in DEFAULTS.items()}
    for key, value in values.items():
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise InputError(f"probes.{key} must be a number, got {value!r}")
    return Probes(
        angle_deg=require_in_range("probes.angle_deg", float(values["angle_deg"]), -360.0, 360.0, "deg"),
        offset_prior_std_m=require_in_range(
            "probes.offset_prior_std_um", float(values["offset_prior_std_um"]), 0.0, 1000.0, "um"
        )
        * 1e-6,
        offset_random_walk_m_sqrt_s=require_in_range(
            "probes.offset_random_walk_um_sqrt_s", float(values["offset_random_walk_um_sqrt_s"]), 0.0, 100.0
        )
        * 1e-6,
    )
