"""``oilwatch coast-down``: a simulated slow coast-down of the machine, as its probes would record it.

A stand-in for the coast-down (or run-up) record a condition-monitoring system keeps: the plant's shaft
centreline from the nominal speed to slow roll (its bearings' static equilibria, solved directly at the
plant's clearance and length, flooded at the nominal supply pressure:
:mod:`oilwatch.models.system.coast_down`), the speed falling exponentially, read by probes with the given
zero offsets and noise. ``oilwatch baseline --coast-down-record`` measures each bearing's clearance from it.
"""

from __future__ import annotations

import dataclasses
import math
import sys

from .baseline import PROBE_COLUMNS
from .machine_option import add_machine_option, load_machine_option


def _structure_field(name: str):
    from oilwatch.models.system.structure import PlantStructure

    return next(f for f in dataclasses.fields(PlantStructure) if f.name == name)


def register(subparsers) -> None:
    """Add the ``coast-down`` subcommand."""
    parser = subparsers.add_parser(
        "coast-down",
        help="simulate a slow coast-down record of the machine (for measuring its bearings' clearances)",
        description=(
            "Simulate a slow coast-down of the machine as its probes would record it: a stand-in for the "
            "coast-down (or run-up) record a condition-monitoring system keeps. The plant's shaft centreline "
            "from the nominal speed to slow roll (its bearings' static equilibria, solved directly at the "
            "plant's clearance and length, flooded at the nominal supply pressure), the speed falling "
            "exponentially, read by probes with the given zero offsets and noise; columns time_s, x1_um, "
            "y1_um, x2_um, y2_um (along the probes' axes), speed_hz, oil_temperature_c. 'oilwatch baseline "
            "--coast-down-record FILE' measures each bearing's clearance from it."
        ),
    )
    add_machine_option(parser)
    parser.add_argument(
        "--duration-s", type=float, default=60.0, help="from the nominal speed to slow roll [s] (60; 10-3600)"
    )
    parser.add_argument(
        "--slow-roll-pct", type=float, default=3.0, help="the last speed, %% of the nominal (3; 0.5-30)"
    )
    parser.add_argument(
        "--noise-um", type=float, default=None, help="probe noise std [um] (the machine file's noise_um)"
    )
    parser.add_argument("--seed", type=int, default=1, help="seed of the noise (1)")
    for name in ("clearance_factor", "length_factor"):
        meta = _structure_field(name).metadata
        low, high = meta["range"]
        parser.add_argument(
            "--" + name.replace("_", "-"),
            type=float,
            default=1.0,
            help=f"the plant's {meta['description']} (1; {low:g}-{high:g})",
        )
    parser.add_argument(
        "--offset-um",
        type=float,
        nargs=4,
        default=(0.0, 0.0, 0.0, 0.0),
        metavar=("X1", "Y1", "X2", "Y2"),
        help="the probes' zero offsets [um] (0 0 0 0)",
    )
    parser.add_argument(
        "--out", required=True, metavar="FILE", help="the record to write (.csv, .parquet or .tdms)"
    )
    parser.set_defaults(func=run)


def run(args) -> int:
    """Simulate and write the record."""
    from oilwatch.models.probes import read_probes
    from oilwatch.models.system.coast_down import coast_down_record
    from oilwatch.models.system.measurement import MeasurementChain, ProbeErrors
    from oilwatch.models.system.structure import PlantStructure
    from oilwatch.models.validation import require_in_range
    from oilwatch.records.probes import probe_setup
    from oilwatch.records.writers import write_record

    machine = load_machine_option(args)
    noise_um = probe_setup(machine.raw.get("probes")).noise_um if args.noise_um is None else args.noise_um
    require_in_range("--noise-um", noise_um, 0.0, 50.0, "um")
    require_in_range("--slow-roll-pct", args.slow_roll_pct, 0.5, 30.0, "%")
    for value in args.offset_um:
        require_in_range("--offset-um", value, -500.0, 500.0, "um")
    structure = PlantStructure(clearance_factor=args.clearance_factor, length_factor=args.length_factor)
    chain = MeasurementChain(
        tuple(ProbeErrors(zero_offset_m=v * 1e-6) for v in args.offset_um),
        math.radians(read_probes(machine).angle_deg),
        noise_um * 1e-6,
    )
    record = coast_down_record(
        machine, structure, chain, args.duration_s, args.slow_roll_pct / 100.0, args.seed
    )
    columns = {"time_s": record["time_s"]}
    columns |= {name: record["readings_m"][:, k] * 1e6 for k, name in enumerate(PROBE_COLUMNS)}
    columns |= {"speed_hz": record["speed_hz"], "oil_temperature_c": record["oil_temperature_c"]}
    write_record(args.out, columns)
    speed = record["speed_hz"]
    print(
        f"coast-down {speed[0]:.2f} -> {speed[-1]:.2f} Hz over {record['time_s'][-1]:.1f} s "
        f"({speed.size} samples) written to {args.out}",
        file=sys.stderr,
    )
    return 0
