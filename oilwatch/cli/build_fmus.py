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
            "missing coefficient table at the machine's nominal speed is computed first. Each file appears "
            "under its name complete and validated, or not at all; one build per --out folder at a time. "
            "Exit code 2 on bad input or an output that cannot be written (docs/operations.md)."
        ),
    )
    add_arguments(parser)
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Build the FMUs (in a separate process: building imports the slave modules)."""
    import shutil
    import sys
    from pathlib import Path

    from oilwatch.cosim.fmu_build import build_in_subprocess
    from oilwatch.outputs.lock import output_lock

    from .machine_option import ensure_flowrate_tables, load_machine_option

    machine = load_machine_option(args)
    ensure_flowrate_tables(machine, [machine.nominal_speed_hz], "build-fmus", not args.no_progress)
    out = Path(args.out)
    with output_lock(out, "build-fmus"):
        try:
            sys.stdout.write(build_in_subprocess(out, args.machine, args.only))
        finally:
            # the private build folders of a builder stopped by a signal (the lock makes them this run's)
            for partial in out.glob(".*.partial"):
                shutil.rmtree(partial, ignore_errors=True)
    return 0
