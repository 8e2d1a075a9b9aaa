"""``oilwatch bearing-locus``: the flooded journal locus from slow roll to speed, for measuring clearances.

For each distinct static load of the machine's bearings, the journal position e/c of the flooded bearing at
the nominal supply pressure against the Sommerfeld number (one static equilibrium per node, uniform in ln S
over :data:`oilwatch.models.bearing.centreline.LOCUS_SOMMERFELD_RANGE`): what ``oilwatch baseline
--coast-down-record`` fits a coast-down's shaft centreline with. Written with provenance, by default next to
the machine file as ``tables/<machine stem>_bearing_locus.json``. Cost: about a minute of one core per load
on the production mesh. Without the file, the first coast-down of the machine solves it and keeps it in the
cache.
"""

from __future__ import annotations

import argparse
import datetime
import shlex
import sys
import time
from pathlib import Path

from .machine_option import add_machine_option, add_mesh_option, load_machine_option, mesh_option


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
    parser.set_defaults(func=run)


def run(args) -> int:
    """Compute and write the loci."""
    from oilwatch.models.bearing.centreline import FloodedLocus, save_loci
    from oilwatch.models.rotor.assembly import Rotor
    from oilwatch.models.system.factory import locus_table_name, machine_arguments
    from oilwatch.models.validation import InputError

    machine = load_machine_option(args)
    pressure = machine.lubrication.nominal_supply_pressure_pa
    if pressure != pressure:  # NaN: the file gives only a flowrate
        raise InputError("oilwatch bearing-locus needs the machine file's nominal_supply_pressure_bar")
    mesh = mesh_option(args)
    out = Path(args.out) if args.out else machine.source_path.parent / "tables" / locus_table_name(machine)
    loads = []
    for load in (float(w) for w in Rotor.from_machine(machine).bearing_static_loads_n):
        if not any(abs(load / other - 1.0) < 1e-9 for other in loads):
            loads.append(load)
    started = time.perf_counter()
    loci = []
    for load in loads:
        print(f"flooded locus at {load:.1f} N, {pressure / 1e5:g} bar ...", file=sys.stderr)
        loci.append(FloodedLocus.compute(machine.bearing, load, pressure, mesh))
    parts = ["oilwatch", "bearing-locus", *machine_arguments(machine)]
    if args.mesh is not None:
        parts += ["--mesh", *map(str, args.mesh)]
    provenance = {
        "command_line": shlex.join(parts + (["--out", args.out] if args.out else [])),
        "machine_file": machine.source_path.name,
        "date_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "compute_s": round(time.perf_counter() - started, 1),
    }
    save_loci(out, loci, provenance)
    print(f"{len(loci)} loci in {provenance['compute_s']:.0f} s written to {out}", file=sys.stderr)
    return 0
