"""``oilwatch build-fmus``: build both FMUs and the SSP system from the installed package (no source tree)."""

from __future__ import annotations

import argparse


def register(subparsers) -> None:
    """Add the ``build-fmus`` subcommand."""
    from oilwatch.cosim.fmu_build import add_arguments

    parser = subparsers.add_parser(
        "build-fmus",
        help="build RotorBearingPlant.fmu, OilFlowEKF.fmu and OilStarvation.ssp for a machine",
        description=(
            "Build the plant FMU, the estimator FMU and the OilStarvation.ssp system (the machine's sudden "
            "drop) from the installed oilwatch package into --out. The FMUs bundle the machine file and its "
            "coefficient tables, so that they run in any FMI host with only numpy, scipy and numba. A "
            "missing coefficient table at the machine's nominal speed is computed first. Exit code 2 on "
            "bad input."
        ),
    )
    add_arguments(parser)
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Build the FMUs (in a separate process: building imports the slave modules)."""
    import sys

    from oilwatch.cosim.fmu_build import build_in_subprocess

    from .machine_option import ensure_flowrate_tables, load_machine_option

    machine = load_machine_option(args)
    ensure_flowrate_tables(machine, [machine.nominal_speed_hz], "build-fmus", not args.no_progress)
    sys.stdout.write(build_in_subprocess(args.out, args.machine, args.only))
    return 0
