"""``oilwatch bearing-locus``: the flooded journal locus from slow roll to speed, for measuring clearances.

For each distinct static load of the machine's bearings, the journal position e/c of the flooded bearing at
the nominal supply pressure against the Sommerfeld number (one static equilibrium per node, uniform in ln S
over :data:`oilwatch.models.bearing.centreline.LOCUS_SOMMERFELD_RANGE`): what ``oilwatch baseline
--coast-down-record`` fits a coast-down's shaft centreline with. Written with provenance, by default next to
the machine file as ``tables/<machine stem>_bearing_locus.json`` (a machine whose bearings differ: one
file per distinct bearing geometry, ``tables/<machine stem>_bearing<N>_locus.json`` for the first bearing N
of that geometry, over the loads of the bearings of that geometry; ``--bearing N``: that one only). Cost:
about a minute of one core per load on the production mesh. Without the file, the first coast-down of the
machine solves it and keeps it in the cache.
"""

from __future__ import annotations

import argparse
import datetime
import shlex
import sys
import time
from pathlib import Path

from .machine_option import (
    TABLE_BEARING_HELP,
    add_bearing_option,
    add_machine_option,
    add_mesh_option,
    bearing_indices,
    load_machine_option,
    mesh_option,
)


def register(subparsers) -> None:
    """Add the ``bearing-locus`` subcommand."""
    parser = subparsers.add_parser(
        "bearing-locus",
        help="compute the flooded journal locus (slow roll to speed) the clearance is measured with",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_machine_option(parser)
    add_mesh_option(parser)
    parser.add_argument("--out", help="output JSON; default <machine dir>/tables/<stem>_bearing_locus.json")
    add_bearing_option(parser, *TABLE_BEARING_HELP)
    parser.set_defaults(func=run)


def run(args) -> int:
    """Compute and write the loci (one file per distinct bearing geometry)."""
    from oilwatch.models.rotor.assembly import Rotor
    from oilwatch.models.validation import InputError

    machine = load_machine_option(args)
    pressure = machine.lubrication.nominal_supply_pressure_pa
    if pressure != pressure:  # NaN: the file gives only a flowrate
        raise InputError("oilwatch bearing-locus needs the machine file's nominal_supply_pressure_bar")
    all_loads = [float(w) for w in Rotor.from_machine(machine).bearing_static_loads_n]
    for index in bearing_indices(machine, args.bearing, "--out" if args.out else None):
        bearing = machine.bearings[index]
        loads = []
        for load in (w for b, w in zip(machine.bearings, all_loads, strict=True) if b == bearing):
            if not any(abs(load / other - 1.0) < 1e-9 for other in loads):
                loads.append(load)
        write_loci(args, machine, index, loads, pressure)
    return 0


def write_loci(args, machine, bearing_index: int, loads: list[float], pressure: float) -> None:
    """Compute the flooded loci of bearing ``bearing_index``'s geometry at ``loads`` [N] and write them."""
    from oilwatch.models.bearing.centreline import FloodedLocus, save_loci
    from oilwatch.models.system.factory import bearing_arguments, locus_table_name, machine_arguments

    mesh = mesh_option(args)
    name = locus_table_name(machine, bearing_index)
    out = Path(args.out) if args.out else machine.source_path.parent / "tables" / name
    started = time.perf_counter()
    loci = []
    for load in loads:
        print(f"flooded locus at {load:.1f} N, {pressure / 1e5:g} bar ...", file=sys.stderr)
        loci.append(FloodedLocus.compute(machine.bearings[bearing_index], load, pressure, mesh))
    parts = ["oilwatch", "bearing-locus", *machine_arguments(machine)]
    if args.mesh is not None:
        parts += ["--mesh", *map(str, args.mesh)]
    parts += bearing_arguments(machine, bearing_index)
    provenance = {
        "command_line": shlex.join(parts + (["--out", args.out] if args.out else [])),
        "machine_file": machine.source_path.name,
        "date_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "compute_s": round(time.perf_counter() - started, 1),
    }
    save_loci(out, loci, provenance)
    print(f"{len(loci)} loci in {provenance['compute_s']:.0f} s written to {out}", file=sys.stderr)
