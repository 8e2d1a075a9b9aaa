"""The ``oilwatch`` command line: one module per subcommand, each exposing ``register(subparsers)``.

A subcommand module keeps its heavy imports inside its ``run`` function so that ``oilwatch --help``
stays fast. ``run(args)`` returns the process exit code.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from models.validation import InputError

# Subcommand modules under oilwatch.cli, in the order --help lists them.
SUBCOMMANDS: tuple[str, ...] = (
    "rotor",
    "modes",
    "campbell",
    "speed_sweep",
    "orbits",
    "report",
    "bearing",
    "bearing_table",
    "study",
    "run",
    "demo",
    "robustness",
    "baseline",
)


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="oilwatch",
        description="Detect and quantify oil starvation in fluid-film bearings from rotor vibration.",
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in SUBCOMMANDS:
        importlib.import_module(f"{__name__}.{name}").register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``oilwatch`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except InputError as error:
        print(f"oilwatch {args.command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"oilwatch {args.command}: interrupted", file=sys.stderr)
        return 130


def console_main() -> None:
    """The console script: :func:`main`, then exit without interpreter finalization if an FMU was loaded.

    pythonfmu 0.7's binary runs its own interpreter teardown when the process ends and may corrupt the
    heap there ("free(): corrupted unsorted chunks", PythonFMU issue #228), turning a finished run's exit
    code into SIGABRT. Every file is closed and both streams are flushed before ``os._exit``.
    """
    code = main()
    if "oilwatch.cosim.loading" in sys.modules and sys.modules["oilwatch.cosim.loading"].instantiated_any():
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":
    console_main()
