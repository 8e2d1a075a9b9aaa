"""Build the rotor-bearing system from a machine file and its coefficient tables.

Where the tables live: next to the machine file, in ``tables/``, named after the machine file's stem:
``tables/<stem>_bearing_<speed>hz[_synchronous].json`` (flowrate table at one speed, ``oilwatch
bearing-table``; the suffix names the kind of coefficients, the machine file's ``[bearings]
dynamic_coefficients``: K, C at whirl frequency = spin speed by default, no suffix for quasi-static) and
``tables/<stem>_speed_sweep.json`` (coefficients over speed at the nominal flowrate,
``oilwatch speed-sweep``). For the bundled machines the committed ones are in ``models/tables/``
(``turbine_bearing_75hz.json``, read-only package data); new tables for them are written to the user cache,
``$OILWATCH_CACHE/tables/`` (default ``~/.cache/oilwatch/tables/``), never into the installed package, and
read from there too. A missing table's error names the one command that makes it (with ``--machine``).

A machine whose bearings differ (``[[bearings.override]]``) has one table of each kind per distinct
bearing geometry, named after the first bearing N (from 1, in ``bearings.nodes`` order) of that geometry
(:func:`geometry_number`): ``<stem>_bearing<N>_<speed>hz[_synchronous].json``,
``<stem>_bearing<N>_locus.json``, ``<stem>_bearing<N>_speed_sweep.json`` and
``<stem>_bearing<N>_dimensionless[_synchronous].json``; the commands that make them take ``--bearing N``.
A machine whose bearings are alike keeps the names above, one table for every bearing.
"""

from __future__ import annotations

import shlex
from pathlib import Path

import numpy as np

from ..bearing.coefficient_kinds import QUASI_STATIC, file_suffix, table_kind
from ..bearing.operating_table import geometry_mismatch
from ..bearing.table import CoefficientTable
from ..cache import user_cache_dir
from ..machine import Machine, bundled_name, is_default_machine, load_machine
from ..rotor.assembly import Rotor
from ..validation import InputError, require_positive
from .reduction import ReductionBasis, craig_bampton
from .rotor_bearing import RotorBearingSystem
from .speed_sweep import SpeedSweep

LOAD_RTOL = 5e-3


def is_bundled(machine: Machine) -> bool:
    """Whether ``machine`` is one of the installed package's bundled machines (read-only package data)."""
    return bundled_name(machine.source_path) is not None


def table_folders(machine: Machine) -> list[Path]:
    """Where the machine's tables are looked for, in order; new tables go into the last one."""
    beside = machine.source_path.parent / "tables"
    return [beside, user_cache_dir() / "tables"] if is_bundled(machine) else [beside]


def machine_files(machine: Machine) -> list[Path]:
    """The machine file and every table of it (``<stem>_*.json`` in each of its table folders)."""
    stem = machine.source_path.stem
    tables = {}
    for folder in table_folders(machine):
        for path in sorted(folder.glob(f"{stem}_*.json")) if folder.is_dir() else []:
            tables.setdefault(path.name, path)  # the first folder wins, as when loading
    return [machine.source_path, *tables.values()]


def _table_path(machine: Machine, name: str) -> Path:
    folders = table_folders(machine)
    for folder in folders:
        if (folder / name).exists():
            return folder / name
    return folders[-1] / name


def new_table_path(machine: Machine, name: str) -> Path:
    """Where a new table called ``name`` of the machine is written (never the installed package)."""
    return table_folders(machine)[-1] / name


def geometry_number(machine: Machine, bearing_index: int = 0) -> int | None:
    """The number N in the names of the tables of bearing ``bearing_index`` (from 0): the first bearing
    (from 1) of its geometry when the machine's bearings differ, None (names without a number) when they are
    alike (module docstring)."""
    return machine.geometry_bearing(bearing_index) if machine.bearings_differ else None


def _bearing_infix(machine: Machine, bearing_index: int) -> str:
    number = geometry_number(machine, bearing_index)
    return "" if number is None else str(number)


def flowrate_table_name(
    machine: Machine, speed_hz: float, coefficients: str | None = None, bearing_index: int = 0
) -> str:
    """File name of the machine's flowrate table at ``speed_hz`` holding ``coefficients`` (a kind of
    :mod:`oilwatch.models.bearing.coefficient_kinds`; None: the machine file's ``dynamic_coefficients``) for
    bearing ``bearing_index`` (from 0; its geometry's table when the bearings differ)."""
    kind = machine.dynamic_coefficients if coefficients is None else coefficients
    infix = _bearing_infix(machine, bearing_index)
    return f"{machine.source_path.stem}_bearing{infix}_{speed_hz:g}hz{file_suffix(kind)}.json"


def flowrate_table_path(
    machine: Machine, speed_hz: float, coefficients: str | None = None, bearing_index: int = 0
) -> Path:
    """Path of the machine's flowrate coefficient table at ``speed_hz`` (of ``coefficients``, None: the
    machine's kind) for bearing ``bearing_index``: the existing one, else where ``oilwatch bearing-table``
    writes it (module docstring)."""
    return _table_path(machine, flowrate_table_name(machine, speed_hz, coefficients, bearing_index))


def flowrate_tables_exist(machine: Machine, speed_hz: float, coefficients: str | None = None) -> bool:
    """Whether the machine's flowrate tables at ``speed_hz`` of ``coefficients`` exist for every bearing."""
    return all(
        flowrate_table_path(machine, speed_hz, coefficients, i).exists() for i in machine.distinct_geometries
    )


def locus_table_name(machine: Machine, bearing_index: int = 0) -> str:
    """File name of the machine's flooded loci (``oilwatch bearing-locus``) of bearing ``bearing_index``."""
    return f"{machine.source_path.stem}_bearing{_bearing_infix(machine, bearing_index)}_locus.json"


def locus_table_path(machine: Machine, bearing_index: int = 0) -> Path:
    """Path of the machine's flooded loci of bearing ``bearing_index``: the existing one, else where a
    computed one is kept."""
    return _table_path(machine, locus_table_name(machine, bearing_index))


def speed_sweep_path(machine: Machine, squeeze: str = "full-film", bearing_index: int = 0) -> Path:
    """Path of the machine's speed sweep (a suffix names a non-default squeeze model) of bearing
    ``bearing_index``: the existing one, else where ``oilwatch speed-sweep`` writes it."""
    return _table_path(machine, speed_sweep_name(machine, squeeze, bearing_index))


def speed_sweep_name(machine: Machine, squeeze: str = "full-film", bearing_index: int = 0) -> str:
    """File name of the machine's speed sweep of bearing ``bearing_index``."""
    suffix = "" if squeeze == "full-film" else f"_squeeze_{squeeze}"
    number = geometry_number(machine, bearing_index)
    bearing = "" if number is None else f"_bearing{number}"
    return f"{machine.source_path.stem}{bearing}_speed_sweep{suffix}.json"


def machine_arguments(machine: Machine) -> list[str]:
    """The ``--machine`` option naming ``machine`` in a command: nothing for the default (the bundled
    turbine), another bundled machine's name, else the machine file."""
    if is_default_machine(machine):
        return []
    return ["--machine", bundled_name(machine.source_path) or str(machine.source_path)]


def bearing_arguments(machine: Machine, bearing_index: int = 0) -> list[str]:
    """The ``--bearing N`` option of a command that makes one table of bearing ``bearing_index``: N its
    geometry's number (:func:`geometry_number`), nothing when the machine's bearings are alike."""
    number = geometry_number(machine, bearing_index)
    return [] if number is None else ["--bearing", str(number)]


def table_command(
    machine: Machine, speed_hz: float, coefficients: str | None = None, bearing_index: int | None = 0
) -> str:
    """The command that computes the machine's flowrate table at ``speed_hz`` (of ``coefficients``) for
    bearing ``bearing_index`` (None: the tables of every bearing)."""
    speed = ["--speed-hz", f"{speed_hz:g}"]
    kind = [] if coefficients in (None, machine.dynamic_coefficients) else ["--coefficients", coefficients]
    bearing = [] if bearing_index is None else bearing_arguments(machine, bearing_index)
    return shlex.join(["oilwatch", "bearing-table", *machine_arguments(machine), *speed, *kind, *bearing])


def sweep_command(machine: Machine, squeeze: str = "full-film", bearing_index: int = 0) -> str:
    """The command that computes the machine's speed sweep of bearing ``bearing_index``."""
    squeezing = [] if squeeze == "full-film" else ["--squeeze", squeeze]
    bearing = bearing_arguments(machine, bearing_index)
    return shlex.join(["oilwatch", "speed-sweep", *machine_arguments(machine), *squeezing, *bearing])


def map_command(machine: Machine, kind: str, bearing_index: int = 0) -> str:
    """The command that computes the machine's dimensionless table of ``kind`` for bearing
    ``bearing_index``'s geometry."""
    bearing = bearing_arguments(machine, bearing_index)
    return shlex.join(
        ["oilwatch", "bearing-map", *machine_arguments(machine), "--coefficients", kind, *bearing]
    )


def _refuse_other_geometry(noun: str, path: Path, stored, machine: Machine, index: int, command: str) -> None:
    """InputError when the geometry ``stored`` with the table or sweep at ``path`` (None: it holds none) is
    not bearing ``index``'s."""
    mismatch = None if stored is None else geometry_mismatch(stored, machine.bearings[index])
    if mismatch is not None:
        raise InputError(
            f"{noun} {path} was computed for {mismatch} ({_bearing_name(machine, index)}): recompute it with "
            f"`{command}`"
        )


def _bearing_name(machine: Machine, bearing_index: int) -> str:
    return f"bearing {bearing_index + 1} (node {machine.bearing_nodes[bearing_index]})"


def load_tables(
    machine: Machine,
    rotor: Rotor,
    speed_hz: float,
    path: str | Path | None = None,
    coefficients: str | None = None,
) -> list[CoefficientTable]:
    """One coefficient table per bearing at ``speed_hz`` (its geometry's, :func:`flowrate_table_name`),
    checked against each bearing's static load and against its geometry where the table stores one.

    ``coefficients``: the kind of K, C (None: the machine file's ``dynamic_coefficients``); a table found
    at the default path must hold that kind (an explicit ``path``, one table for every bearing, is taken
    as it is).
    """
    kind = machine.dynamic_coefficients if coefficients is None else coefficients
    loaded: dict[Path, CoefficientTable] = {}
    tables = []
    for index, load in enumerate(rotor.bearing_static_loads_n):
        table_path = Path(path) if path is not None else flowrate_table_path(machine, speed_hz, kind, index)
        command = table_command(machine, speed_hz, kind, index)
        if table_path not in loaded:
            loaded[table_path] = _load_table(table_path, speed_hz, kind, command, check_kind=path is None)
        table = loaded[table_path]
        who = _bearing_name(machine, index)
        if not np.isclose(table.load_n, load, rtol=LOAD_RTOL):
            raise InputError(
                f"coefficient table {table_path} was computed for a load of {table.load_n:.1f} N, but "
                f"{who} carries {load:.1f} N: compute a table for that load"
            )
        # a table made by hand may not say its geometry
        _refuse_other_geometry(
            "coefficient table", table_path, table.metadata.get("bearing"), machine, index, command
        )
        tables.append(table)
    return tables


def _load_table(table_path: Path, speed_hz: float, kind: str, command: str, check_kind: bool):
    if not table_path.exists():
        raise InputError(
            f"speed_hz = {speed_hz:g} Hz: no coefficient table at {table_path}; compute it with `{command}`"
        )
    table = CoefficientTable.load(table_path)
    if check_kind and table_kind(table.metadata) != kind:
        raise InputError(
            f"coefficient table {table_path} holds {table_kind(table.metadata)} coefficients, the machine "
            f"file asks for {kind} (bearings.dynamic_coefficients): recompute it with `{command}`"
        )
    return table


def load_speed_sweeps(
    machine: Machine, rotor: Rotor, path: str | Path | None = None, squeeze: str = "full-film"
) -> list[SpeedSweep]:
    """One speed sweep per bearing (its geometry's, :func:`speed_sweep_name`; an explicit ``path`` is every
    bearing's), checked against each bearing's static load and against its geometry where the sweep stores
    one."""
    loaded: dict[Path, SpeedSweep] = {}
    sweeps = []
    for index, load in enumerate(rotor.bearing_static_loads_n):
        sweep_path = Path(path) if path is not None else speed_sweep_path(machine, squeeze, index)
        if sweep_path not in loaded:
            if not sweep_path.exists():
                raise InputError(
                    f"no speed sweep at {sweep_path}; compute it with "
                    f"`{sweep_command(machine, squeeze, index)}` (a few minutes)"
                )
            loaded[sweep_path] = SpeedSweep.load(sweep_path)
        sweep = loaded[sweep_path]
        who = _bearing_name(machine, index)
        if not np.isclose(sweep.load_n, load, rtol=LOAD_RTOL):
            raise InputError(
                f"speed sweep {sweep_path} was computed for {sweep.load_n:.1f} N, not {load:.1f} N ({who})"
            )
        # the committed turbine sweeps do not hold their geometry
        stored = sweep.provenance.get("bearing")
        _refuse_other_geometry(
            "speed sweep", sweep_path, stored, machine, index, sweep_command(machine, squeeze, index)
        )
        sweeps.append(sweep)
    return sweeps


def build_system(
    machine: Machine,
    speed_hz: float | None = None,
    *,
    reduced: bool = True,
    cutoff_hz: float | None = None,
    table_path: str | Path | None = None,
    unbalance_moment_kg_m: float | None = None,
    unbalance_phase_rad: float | None = None,
    coefficients: str | None = None,
) -> RotorBearingSystem:
    """The rotor-bearing system of a loaded machine at ``speed_hz`` (default: its nominal speed).

    ``reduced`` selects the Craig-Bampton model (bearing dofs, fixed-interface modes below ``cutoff_hz``,
    default the machine file's ``reduced_model.cutoff_hz``, static correction for gravity and unbalance);
    otherwise all physical dofs are kept. The unbalance
    arguments override the machine file's unbalance moment and phase. ``coefficients`` overrides the
    machine file's kind of bearing coefficients: "synchronous" keeps the quasi-static table for the dynamics
    and takes the 1x unbalance response from the synchronous table
    (:mod:`oilwatch.models.system.rotor_bearing`: constant K(Omega), C(Omega) would destabilize the free
    modes); "quasi-static" uses one table for both. An explicit ``table_path`` is used for both, whatever it
    holds.
    """
    speed = machine.nominal_speed_hz if speed_hz is None else require_positive("speed_hz", speed_hz, "Hz")
    rotor = Rotor.from_machine(machine)
    tables, synchronous = _system_tables(machine, rotor, speed, table_path, coefficients)
    basis = rotor_reduction(machine, rotor, cutoff_hz) if reduced else None
    return RotorBearingSystem(
        rotor,
        tables,
        speed,
        basis,
        unbalance_moment_kg_m,
        unbalance_phase_rad,
        machine.lubrication.nominal_flowrates_m3_s,
        synchronous,
    )


def rotor_reduction(machine: Machine, rotor: Rotor, cutoff_hz: float | None = None) -> ReductionBasis:
    """The Craig-Bampton basis of the machine's rotor: its bearing dofs, the fixed-interface modes below
    ``cutoff_hz`` (default the machine file's ``reduced_model.cutoff_hz``), the static correction for gravity
    and the unbalance force."""
    bearing_dofs = [rotor.dof(node, axis) for node in rotor.bearing_nodes for axis in ("x", "y")]
    unit_unbalance = rotor.unbalance_amplitude(1.0)
    loads = np.column_stack([rotor.static_force, unit_unbalance.real, unit_unbalance.imag])
    cutoff = machine.reduction_cutoff_hz if cutoff_hz is None else cutoff_hz
    return craig_bampton(rotor.mass_matrix, rotor.stiffness_matrix, bearing_dofs, cutoff, loads)


def table_kinds(machine: Machine, coefficients: str | None = None) -> tuple[str, ...]:
    """The kinds of flowrate table a system of the machine needs: the quasi-static one (its dynamics) and,
    for ``"synchronous"`` coefficients, the synchronous one (its 1x response;
    oilwatch.models.system.rotor_bearing)."""
    kind = machine.dynamic_coefficients if coefficients is None else coefficients
    return (QUASI_STATIC,) if kind == QUASI_STATIC else (QUASI_STATIC, kind)


def _system_tables(machine, rotor, speed, table_path, coefficients):
    """(dynamics tables, synchronous tables or None): an explicit ``table_path`` is both (as it is)."""
    if table_path is not None:
        return load_tables(machine, rotor, speed, table_path), None
    kinds = table_kinds(machine, coefficients)
    tables = load_tables(machine, rotor, speed, None, QUASI_STATIC)
    return tables, (load_tables(machine, rotor, speed, None, kinds[1]) if len(kinds) > 1 else None)


def load_system(
    machine_file: str | Path | None = None,
    speed_hz: float | None = None,
    *,
    reduced: bool = True,
    cutoff_hz: float | None = None,
    table_path: str | Path | None = None,
    unbalance_moment_kg_m: float | None = None,
    unbalance_phase_rad: float | None = None,
    coefficients: str | None = None,
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
        coefficients=coefficients,
    )
