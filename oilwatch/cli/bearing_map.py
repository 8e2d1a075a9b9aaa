"""``oilwatch bearing-map``: the dimensionless bearing table over Sommerfeld number and supply flowrate.

One table serves any speed, viscosity (oil temperature) and load of the machine's bearing geometry: the
equilibrium eccentricity and attitude, K c / W and C c Omega / W, solved on a grid uniform in ln S (nodes
S_nominal * ratio^k covering the speeds and viscosities asked for, at every bearing's load) and in the
supply flowrate as a fraction of the flooded threshold (the machine file's table fractions, a node on
f = 1). Written with provenance, by default next to the machine file as
``tables/<machine stem>_bearing_dimensionless.json`` (a machine whose bearings differ: one table per
distinct bearing geometry over the loads of its bearings,
``tables/<machine stem>_bearing<N>_dimensionless.json`` for the first bearing N of that geometry;
``--bearing N``: that one only). Cost: about 3 s of one core per point on the
production mesh (bundled turbine, 12 x 13 points: about 10 minutes); run it under ``nice``.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from .machine_option import (
    TABLE_BEARING_HELP,
    add_bearing_option,
    add_coefficients_option,
    add_fraction_range_option,
    add_machine_option,
    add_mesh_option,
    bearing_indices,
    check_fraction_range,
    load_machine_option,
    mesh_option,
)

DEFAULT_SPEED_RANGE = (0.6, 1.4)
DEFAULT_VISCOSITY_RANGE = (0.5, 2.0)
DEFAULT_SOMMERFELD_RATIO = 1.25
DEFAULT_FRACTIONS = 13


def register(subparsers) -> None:
    """Add the ``bearing-map`` subcommand."""
    parser = subparsers.add_parser(
        "bearing-map",
        help="compute the dimensionless bearing table (any speed, viscosity, load and flowrate)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_machine_option(parser)
    add_fraction_range_option(parser, "speed", DEFAULT_SPEED_RANGE, "speeds")
    add_fraction_range_option(parser, "viscosity", DEFAULT_VISCOSITY_RANGE, "viscosities")
    parser.add_argument(
        "--sommerfeld-ratio",
        type=float,
        default=DEFAULT_SOMMERFELD_RATIO,
        help="ratio between neighbouring Sommerfeld nodes (1.25)",
    )
    parser.add_argument(
        "--fractions",
        type=int,
        default=DEFAULT_FRACTIONS,
        help="flowrate nodes over the machine's table fractions of q_t, one on q_t (13)",
    )
    add_mesh_option(parser)
    parser.add_argument(
        "--out", help="output JSON; default <machine dir>/tables/<stem>_bearing_dimensionless.json"
    )
    add_coefficients_option(parser, "the file name follows: ..._dimensionless_synchronous.json")
    parser.add_argument(
        "--reuse",
        metavar="TABLE",
        help="an earlier table of the same nodes, mesh, kind, speed and load: its node values are kept and "
        "only what it lacks is solved (the one-sided limits on the flooded threshold of an older table)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    add_bearing_option(parser, *TABLE_BEARING_HELP)
    parser.set_defaults(func=run)


def fraction_nodes(low: float, high: float, count: int):
    """``count`` uniform nodes over [low, high] with one exactly on 1 (the flooded threshold)."""
    import numpy as np

    from oilwatch.models.validation import InputError

    if count < 3:
        raise InputError(f"--fractions must be >= 3, got {count}")
    nodes = np.linspace(low, high, count)
    k = np.argmin(np.abs(nodes - 1.0))
    if not low < 1.0 < high or abs(nodes[k] - 1.0) > 1e-9 * (high - low):
        raise InputError(
            f"--fractions {count} over [{low:g}, {high:g}] of q_t puts no node on the flooded threshold (1): "
            "choose a count with (1 - low) / (high - low) * (count - 1) a whole number"
        )
    nodes[k] = 1.0
    return nodes


def run(args) -> int:
    """Compute and write the table (one per distinct bearing geometry)."""
    from oilwatch.models.rotor.assembly import Rotor

    check_fraction_range("--speed-range", args.speed_range)
    check_fraction_range("--viscosity-range", args.viscosity_range)
    machine = load_machine_option(args)
    all_loads = [float(w) for w in Rotor.from_machine(machine).bearing_static_loads_n]
    single = next((option for option, value in (("--out", args.out), ("--reuse", args.reuse)) if value), None)
    for index in bearing_indices(machine, args.bearing, single):
        bearing = machine.bearings[index]
        loads = [w for b, w in zip(machine.bearings, all_loads, strict=True) if b == bearing]
        write_map(args, machine, index, loads)
    return 0


def write_map(args, machine, bearing_index: int, loads: list[float]) -> None:
    """Compute and write the table of bearing ``bearing_index``'s geometry over the Sommerfeld numbers of
    ``loads`` [N] (its load first) and the asked speeds and viscosities."""
    from tqdm import tqdm

    from oilwatch.models.bearing.operating_table import OperatingTable, operating_table_path
    from oilwatch.models.bearing.operating_table_solve import compute_operating_table
    from oilwatch.models.bearing.sommerfeld import sommerfeld_grid, sommerfeld_number
    from oilwatch.models.system.factory import bearing_arguments, geometry_number

    bearing, speed = machine.bearings[bearing_index], machine.nominal_speed_hz
    nominal = sommerfeld_number(bearing, bearing.viscosity_pa_s, speed, loads[0])
    spread = args.speed_range[0] * args.viscosity_range[0], args.speed_range[1] * args.viscosity_range[1]
    low = min(sommerfeld_number(bearing, bearing.viscosity_pa_s, speed, w) for w in loads) * spread[0]
    high = max(sommerfeld_number(bearing, bearing.viscosity_pa_s, speed, w) for w in loads) * spread[1]
    s_nodes = sommerfeld_grid(nominal, low, high, args.sommerfeld_ratio)
    lub = machine.lubrication
    f_nodes = fraction_nodes(
        lub.table_min_fraction_of_threshold, lub.table_max_fraction_of_threshold, args.fractions
    )
    mesh = mesh_option(args)
    kind = args.coefficients or machine.dynamic_coefficients
    number = geometry_number(machine, bearing_index)
    out = Path(args.out) if args.out else operating_table_path(machine.source_path, kind, number)
    checkpoint = out.with_name(out.stem + ".partial.json")
    total = s_nodes.size * f_nodes.size
    print(
        f"Sommerfeld {s_nodes[0]:.4g} .. {s_nodes[-1]:.4g} ({s_nodes.size} nodes, nominal {nominal:.4g}), "
        f"{f_nodes.size} flowrates: {total} points, {kind} coefficients (finished Sommerfeld nodes kept in "
        f"{checkpoint})",
        file=sys.stderr,
    )
    with tqdm(total=total, desc="bearing map", unit="point", disable=args.quiet) as bar:
        table = compute_operating_table(
            bearing,
            loads[0],
            speed,
            s_nodes,
            f_nodes,
            mesh,
            progress=bar.update,
            coefficients=kind,
            checkpoint=checkpoint,
            reuse=None if args.reuse is None else OperatingTable.load(args.reuse),
            provenance={
                "command_line": command_line(args, bearing_arguments(machine, bearing_index)),
                "machine_file": machine.source_path.name,  # its name: no folder of the machine that made it
                "nominal_sommerfeld": nominal,
            },
        )
    out.parent.mkdir(parents=True, exist_ok=True)
    table.save(out)
    checkpoint.unlink(missing_ok=True)
    print(
        f"{total} points in {table.metadata['provenance']['compute_s']:.0f} s written to {out}",
        file=sys.stderr,
    )


def command_line(args, bearing: list[str]) -> str:
    """The command that reproduces this table (from the parsed options; ``bearing``: its ``--bearing N``)."""
    parts = ["oilwatch", "bearing-map"]
    if args.machine:
        parts += ["--machine", args.machine]
    parts += [
        "--speed-range",
        *map(str, args.speed_range),
        "--viscosity-range",
        *map(str, args.viscosity_range),
        "--sommerfeld-ratio",
        str(args.sommerfeld_ratio),
        "--fractions",
        str(args.fractions),
    ]
    if args.coefficients:
        parts += ["--coefficients", args.coefficients]
    if args.mesh is not None:
        parts += ["--mesh", *map(str, args.mesh)]
    if args.out:
        parts += ["--out", args.out]
    if args.reuse:
        parts += ["--reuse", args.reuse]
    return shlex.join(parts + bearing)
