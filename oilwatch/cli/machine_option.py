"""``--machine FILE``, the same on every command that uses a machine, and the tables such a command needs.

A machine file is a TOML file with units in its keys (``models/machine.py``); without ``--machine`` a command
uses the bundled generic turbine. Its coefficient tables live in ``tables/`` beside the file (the bundled
turbine: its committed tables, and new ones in the user cache ``$OILWATCH_CACHE/tables``; see
``oilwatch.models.system.factory``). A command that needs a flowrate table that does not exist computes it
here (about 20 s, with a progress bar); a missing speed sweep (a few minutes) is not computed silently: the
error names the one command that makes it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

MACHINE_HELP = (
    "machine file (TOML, units in the keys), or a bundled machine by name (turbine, compressor); default: "
    "the bundled generic turbine"
)
TABLE_POINTS = 7
"""Flowrates of a table computed on demand (the paper's 7, as ``oilwatch bearing-table``)."""


def add_machine_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--machine FILE`` (default: the bundled generic turbine)."""
    parser.add_argument("--machine", metavar="FILE", default=None, type=_machine_file, help=MACHINE_HELP)


def _machine_file(value: str) -> str:
    """``--machine``'s value as a path: a bundled machine's file for its name."""
    from oilwatch.models.machine import machine_file_path

    return str(machine_file_path(value))


def add_mesh_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--mesh N_CIRC N_AXIAL``, the film's finite volumes (:func:`mesh_option` reads it)."""
    parser.add_argument(
        "--mesh",
        type=int,
        nargs=2,
        metavar=("N_CIRC", "N_AXIAL"),
        help="finite volumes around x along the bearing; default: the production mesh",
    )


def mesh_option(args: argparse.Namespace):
    """The :class:`oilwatch.models.bearing.grid.Mesh` of ``--mesh`` (the production mesh without it)."""
    from oilwatch.models.bearing.grid import PRODUCTION_MESH, Mesh

    return PRODUCTION_MESH if args.mesh is None else Mesh(*args.mesh)


def add_coefficients_option(parser: argparse.ArgumentParser, default_file: str) -> None:
    """Add ``--coefficients KIND``, the kinds of :mod:`oilwatch.models.bearing.coefficient_kinds` (default:
    the machine file's ``bearings.dynamic_coefficients``); ``default_file`` says which file that writes."""
    from oilwatch.models.bearing.coefficient_kinds import COEFFICIENT_KINDS, QUASI_STATIC, SYNCHRONOUS

    parser.add_argument(
        "--coefficients",
        choices=tuple(COEFFICIENT_KINDS),
        help=f"K, C of the films: {SYNCHRONOUS!r} (at whirl frequency = spin speed) or {QUASI_STATIC!r}; "
        f"default: the machine file's bearings.dynamic_coefficients ({default_file})",
    )


def add_fraction_range_option(
    parser: argparse.ArgumentParser, name: str, default: tuple[float, float], what: str
) -> None:
    """Add ``--<name>-range LOW HIGH``: the ``what`` to cover, as fractions of the nominal (see
    :func:`check_fraction_range`)."""
    parser.add_argument(
        f"--{name}-range",
        type=float,
        nargs=2,
        metavar=("LOW", "HIGH"),
        default=default,
        help=f"{what} to cover, as fractions of the nominal ({default[0]:g} {default[1]:g}; "
        "0 < LOW <= 1 <= HIGH)",
    )


def check_fraction_range(option: str, value: tuple[float, float]) -> tuple[float, float]:
    """``value`` of a :func:`add_fraction_range_option` option, or InputError naming ``option``."""
    from oilwatch.models.validation import InputError

    low, high = value
    if not 0 < low <= 1.0 <= high:
        raise InputError(f"{option} must satisfy 0 < LOW <= 1 <= HIGH, got {low:g} {high:g}")
    return low, high


def add_bearing_option(parser: argparse.ArgumentParser, what: str, default: str) -> None:
    """Add ``--bearing N`` (:func:`bearing_index`, :func:`bearing_indices` read it): ``what`` of bearing N,
    ``default`` without it."""
    parser.add_argument(
        "--bearing",
        type=int,
        metavar="N",
        help=f"bearing N (from 1, in the machine file's bearings.nodes order): {what}; default: {default}",
    )


def bearing_index(machine, number: int) -> int:
    """The index (from 0) of bearing ``number`` (``--bearing N``, from 1), or InputError."""
    from oilwatch.models.validation import InputError

    count = len(machine.bearings)
    if not 1 <= number <= count:
        raise InputError(
            f"--bearing must be a bearing number 1..{count} (bearings.nodes {list(machine.bearing_nodes)}), "
            f"got {number}"
        )
    return number - 1


def bearing_indices(machine, number: int | None, single: str | None = None) -> list[int]:
    """The bearings (from 0) whose geometry a table command makes a table for: the first bearing of bearing
    ``number``'s geometry (``--bearing N``, from 1), else the first bearing of each distinct geometry.
    ``single`` names an option given that takes one table: with it, a machine whose bearings differ needs
    ``--bearing``."""
    from oilwatch.models.validation import InputError

    if number is not None:
        return [machine.geometry_bearing(bearing_index(machine, number)) - 1]
    indices = list(machine.distinct_geometries)
    if single is not None and len(indices) > 1:
        raise InputError(
            f"{single} takes one table, and the bearings of {machine.name} differ: add --bearing N"
        )
    return indices


TABLE_BEARING_HELP = (
    "the table of its geometry (named after the first bearing of that geometry)",
    "one table for each distinct bearing geometry (one for every bearing when they are alike)",
)
"""``what`` and ``default`` of :func:`add_bearing_option` for a command that makes tables."""


def load_machine_option(args: argparse.Namespace):
    """The machine of ``--machine`` (an InputError names a bad file)."""
    from oilwatch.models.machine import load_machine

    return load_machine(args.machine)


def compute_flowrate_table(
    machine,
    speed_hz: float,
    *,
    points: int = TABLE_POINTS,
    load_n: float | None = None,
    mesh=None,
    out: Path | None = None,
    progress: bool = True,
    command: str | None = None,
    coefficients: str | None = None,
    bearing_index: int = 0,
):
    """Compute the machine's flowrate coefficient table at ``speed_hz`` for bearing ``bearing_index`` (from 0;
    its geometry and static load) and write it (default: where the machine's tables go); return
    ``(path, table, q_t [m^3/s])``. ``command`` is recorded as provenance (default: the ``oilwatch
    bearing-table`` command that makes the same table). ``coefficients``: the kind of K, C (None: the machine
    file's ``bearings.dynamic_coefficients``)."""
    import numpy as np

    from oilwatch.models.bearing.table import compute_table, flooded_threshold
    from oilwatch.models.rotor.assembly import Rotor
    from oilwatch.models.system.factory import flowrate_table_name, new_table_path, table_command

    from .progress import progress_bar

    kind = machine.dynamic_coefficients if coefficients is None else coefficients
    bearing = machine.bearings[bearing_index]
    if load_n is None:
        load_n = float(Rotor.from_machine(machine).bearing_static_loads_n[bearing_index])
    q_t, _ = flooded_threshold(bearing, load_n, speed_hz, mesh)
    lubrication = machine.lubrication
    flows = q_t * np.linspace(
        lubrication.table_min_fraction_of_threshold, lubrication.table_max_fraction_of_threshold, points
    )
    with progress_bar(f"bearing table {speed_hz:g} Hz", "flowrate", progress) as callback:
        table = compute_table(
            bearing,
            load_n,
            speed_hz,
            flows,
            mesh,
            progress=callback,
            flooded_threshold_m3_s=q_t,
            coefficients=kind,
            provenance={
                "command_line": command or table_command(machine, speed_hz, kind, bearing_index),
                "machine_file": machine.source_path.name,  # its name: no folder of the machine that made it
            },
        )
    name = flowrate_table_name(machine, speed_hz, kind, bearing_index)
    path = out if out is not None else new_table_path(machine, name)
    path.parent.mkdir(parents=True, exist_ok=True)
    table.save(path)
    return path, table, q_t


def ensure_flowrate_tables(machine, speeds_hz, command: str, progress: bool = True) -> list[Path]:
    """The machine's flowrate tables at ``speeds_hz`` (every kind its models need: ``table_kinds``; one per
    distinct bearing geometry), each computed first (said on stderr) when missing."""
    from oilwatch.models.system.factory import flowrate_table_path, table_command, table_kinds

    paths = []
    for speed in sorted({float(s) for s in speeds_hz}):
        for kind in table_kinds(machine):
            for index in machine.distinct_geometries:
                path = flowrate_table_path(machine, speed, kind, index)
                if not path.exists():
                    same = table_command(machine, speed, kind, index)
                    print(
                        f"oilwatch {command}: no {kind} coefficient table for {machine.name} at "
                        f"{speed:g} Hz; computing it (the same as `{same}`)",
                        file=sys.stderr,
                    )
                    path, _, _ = compute_flowrate_table(
                        machine, speed, progress=progress, coefficients=kind, bearing_index=index
                    )
                    print(f"oilwatch {command}: wrote {path}", file=sys.stderr)
                paths.append(path)
    return paths
