"""Build the rotor-bearing system from a machine file and its coefficient tables.

Where the tables live: next to the machine file, in ``tables/``, named after the machine file's stem:
``tables/<stem>_bearing_<speed>hz.json`` (flowrate table at one speed, ``oilwatch bearing-table``) and
``tables/<stem>_speed_sweep.json`` (coefficients over speed at the nominal flowrate,
``oilwatch speed-sweep``).
For the bundled generic turbine that is ``models/tables/turbine_bearing_75hz.json``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..bearing.table import CoefficientTable
from ..machine import Machine, load_machine
from ..rotor.assembly import Rotor
from ..validation import InputError, require_positive
from .reduction import craig_bampton
from .rotor_bearing import RotorBearingSystem
from .speed_sweep import SpeedSweep

DEFAULT_CUTOFF_HZ = 500.0
"""Fixed-interface modes kept by the reduced model: below 500 Hz, the Nyquist frequency of 1 kHz sampling."""

LOAD_RTOL = 5e-3


def flowrate_table_path(machine: Machine, speed_hz: float) -> Path:
    """Default path of the machine's flowrate coefficient table at ``speed_hz``."""
    return machine.source_path.parent / "tables" / f"{machine.source_path.stem}_bearing_{speed_hz:g}hz.json"


def speed_sweep_path(machine: Machine, squeeze: str = "full-film") -> Path:
    """Default path of the machine's speed sweep (a suffix names a non-default squeeze model)."""
    suffix = "" if squeeze == "full-film" else f"_squeeze_{squeeze}"
    return machine.source_path.parent / "tables" / f"{machine.source_path.stem}_speed_sweep{suffix}.json"


def load_tables(machine: Machine, rotor: Rotor, speed_hz: float, path: str | Path | None = None):
    """One coefficient table per bearing at ``speed_hz``, checked against each bearing's static load."""
    table_path = Path(path) if path is not None else flowrate_table_path(machine, speed_hz)
    if not table_path.exists():
        raise InputError(
            f"speed_hz = {speed_hz:g} Hz: no coefficient table at {table_path}; compute it with "
            f"`oilwatch bearing-table --speed-hz {speed_hz:g}`"
        )
    table = CoefficientTable.load(table_path)
    for node, load in zip(rotor.bearing_nodes, rotor.bearing_static_loads_n, strict=True):
        if not np.isclose(table.load_n, load, rtol=LOAD_RTOL):
            raise InputError(
                f"coefficient table {table_path} was computed for a load of {table.load_n:.1f} N, but the "
                f"bearing at node {node} carries {load:.1f} N: compute a table for that load"
            )
    return [table] * len(rotor.bearing_nodes)


def load_speed_sweeps(
    machine: Machine, rotor: Rotor, path: str | Path | None = None, squeeze: str = "full-film"
) -> list[SpeedSweep]:
    """One speed sweep per bearing (all bearings of a machine file share the geometry and the load)."""
    sweep_path = Path(path) if path is not None else speed_sweep_path(machine, squeeze)
    if not sweep_path.exists():
        raise InputError(f"no speed sweep at {sweep_path}; compute it with `oilwatch speed-sweep`")
    sweep = SpeedSweep.load(sweep_path)
    for load in rotor.bearing_static_loads_n:
        if not np.isclose(sweep.load_n, load, rtol=LOAD_RTOL):
            raise InputError(
                f"speed sweep {sweep_path} was computed for {sweep.load_n:.1f} N, not {load:.1f} N"
            )
    return [sweep] * len(rotor.bearing_nodes)


def build_system(
    machine: Machine,
    speed_hz: float | None = None,
    *,
    reduced: bool = True,
    cutoff_hz: float = DEFAULT_CUTOFF_HZ,
    table_path: str | Path | None = None,
    unbalance_moment_kg_m: float | None = None,
    unbalance_phase_rad: float | None = None,
) -> RotorBearingSystem:
    """The rotor-bearing system of a loaded machine at ``speed_hz`` (default: its nominal speed).

    ``reduced`` selects the Craig-Bampton model (bearing dofs, fixed-interface modes below ``cutoff_hz``,
    static correction for gravity and unbalance); otherwise all physical dofs are kept. The unbalance
    arguments override the machine file's unbalance moment and phase.
    """
    speed = machine.nominal_speed_hz if speed_hz is None else require_positive("speed_hz", speed_hz, "Hz")
    rotor = Rotor.from_machine(machine)
    tables = load_tables(machine, rotor, speed, table_path)
    basis = None
    if reduced:
        bearing_dofs = [rotor.dof(node, axis) for node in rotor.bearing_nodes for axis in ("x", "y")]
        unit_unbalance = rotor.unbalance_amplitude(1.0)
        loads = np.column_stack([rotor.gravity_force, unit_unbalance.real, unit_unbalance.imag])
        basis = craig_bampton(rotor.mass_matrix, rotor.stiffness_matrix, bearing_dofs, cutoff_hz, loads)
    return RotorBearingSystem(rotor, tables, speed, basis, unbalance_moment_kg_m, unbalance_phase_rad)


def load_system(
    machine_file: str | Path | None = None,
    speed_hz: float | None = None,
    *,
    reduced: bool = True,
    cutoff_hz: float = DEFAULT_CUTOFF_HZ,
    table_path: str | Path | None = None,
    unbalance_moment_kg_m: float | None = None,
    unbalance_phase_rad: float | None = None,
) -> RotorBearingSystem:
    """:func:`build_system` for a machine file (None: the bundled generic turbine)."""
    return build_system(
        load_machine(machine_file),
        speed_hz,
        reduced=reduced,
        cutoff_hz=cutoff_hz,
        table_path=table_path,
        unbalance_moment_kg_m=unbalance_moment_kg_m,
        unbalance_phase_rad=unbalance_phase_rad,
    )
