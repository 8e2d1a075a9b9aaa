"""The machine parameters both oilwatch FMUs share: ``machine_file``, ``speed_hz`` and the unbalance.

Both the plant and the estimator build the same rotor-bearing system from the same parameters (the filter
must know the machine and the unbalance the plant has), so they build it here.
"""

from __future__ import annotations

import math
from pathlib import Path

from models.machine import BUNDLED_MACHINE, load_machine
from models.system.factory import build_system
from models.system.rotor_bearing import RotorBearingSystem
from models.validation import InputError


def bundled_machine_file(resources: str | None) -> Path:
    """The bundled machine file inside an FMU instance's resources folder.

    Found through the instance's own ``resources`` path, not the module's ``__file__``: a host that loads the
    FMU twice imports the (relocated) package once, from the first extraction folder, which it may have
    deleted since.
    """
    if not resources:
        return BUNDLED_MACHINE
    package = load_machine.__module__.split(".")[0]
    return Path(resources) / package / BUNDLED_MACHINE.name


def rotor_bearing_system(
    machine_file: str,
    resources: str | None,
    speed_hz: float,
    unbalance_g_mm: float,
    unbalance_phase_deg: float,
    *,
    reduced: bool,
) -> RotorBearingSystem:
    """The system of the FMU parameters: ``machine_file`` (empty: the bundled turbine), ``speed_hz``,
    ``unbalance_g_mm`` (negative: the machine file's ISO-grade unbalance) and ``unbalance_phase_deg``."""
    if machine_file and not Path(machine_file).is_file():
        raise InputError(f"machine_file: no such file: {machine_file!r}")
    machine = load_machine(machine_file or bundled_machine_file(resources))
    return build_system(
        machine,
        speed_hz,
        reduced=reduced,
        unbalance_moment_kg_m=None if unbalance_g_mm < 0.0 else unbalance_g_mm * 1e-6,
        unbalance_phase_rad=math.radians(unbalance_phase_deg),
    )
