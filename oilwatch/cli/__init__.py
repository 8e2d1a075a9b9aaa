"""The ``oilwatch`` command line: one module per subcommand, each exposing ``register(subparsers)``.

A subcommand module keeps its heavy imports inside its ``run`` function so that ``oilwatch --help``
stays fast. ``run(args)`` returns the process exit code.
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys

from oilwatch.models.validation import InputError

# Subcommand modules under oilwatch.cli, in the order --help lists them: first what a user runs on a machine
# (monitoring its records, the demo, the co-simulation, the FMUs), then the studies, then the modelling
# commands.
USER_COMMANDS: tuple[str, ...] = ("estimate", "baseline", "demo", "run", "coast_down", "build_fmus")
STUDY_COMMANDS: tuple[str, ...] = ("robustness", "study", "report", "orbits")
MODELLING_COMMANDS: tuple[str, ...] = (
    "rotor",
    "modes",
    "campbell",
    "speed_sweep",
    "transient",
    "bearing",
    "bearing_table",
    "bearing_map",
    "bearing_locus",
    "validate",
)
SUBCOMMANDS: tuple[str, ...] = USER_COMMANDS + STUDY_COMMANDS + MODELLING_COMMANDS


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (the command, the argument, what is allowed, where
    to look) with exit code 2, like the errors the commands raise themselves."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


OUTPUTS: dict[str, dict[str, str]] = {
    "run": {"out": "folder"},
    "estimate": {"out": "folder"},
    "demo": {"out": "folder"},
    "study": {"out": "folder"},
    "orbits": {"out": "file"},
    "campbell": {"out": "file"},
    "speed-sweep": {"out": "file"},
    "bearing-table": {"out": "file", "plot": "file"},
    "build-fmus": {"out": "folder"},
    "robustness": {"out": "folder"},
    "baseline": {"out": "file"},
    "bearing-locus": {"out": "file"},
    "coast-down": {"out": "file"},
}
"""Each command's output options (argparse dest -> ``folder`` or ``file``), checked by :func:`main` before
the command runs (:mod:`oilwatch.cli.outputs`). A new command with an output option adds its line here."""


def check_outputs(args: argparse.Namespace) -> None:
    """Check the output options the user gave (creating nothing); InputError naming the flag."""
    from .outputs import check_output

    for dest, kind in OUTPUTS.get(args.command, {}).items():
        value = getattr(args, dest, None)
        if value is not None:
            check_output("--" + dest.replace("_", "-"), value, kind)


def package_version() -> str:
    """The installed distribution's version (pyproject.toml's); "unknown" from an uninstalled tree."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("oilwatch")
    except PackageNotFoundError:
        return "unknown"


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level parser with every subcommand registered."""
    parser = OneLineParser(
        prog="oilwatch",
        description=(
            "Detect and quantify oil starvation in fluid-film bearings from rotor vibration. "
            "A machine's records: baseline, then estimate. Simulated records and the FMUs: demo, run, "
            "coast-down, build-fmus. "
            "The studies and the modelling commands follow."
        ),
    )
    parser.add_argument("--version", action="version", version=f"oilwatch {package_version()}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in SUBCOMMANDS:
        importlib.import_module(f"{__name__}.{name}").register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``oilwatch`` console script (and of tests that run a command in-process).

    Exit codes: 0 done; 1 done, with a finding the summary calls out (:mod:`oilwatch.monitoring.health`);
    2 bad input, or an output that cannot be written (one line naming the path and what was kept);
    130 SIGINT, 143 SIGTERM (one line saying what was kept). docs/operations.md.
    """
    from oilwatch.outputs import interrupts, ledger
    from oilwatch.outputs.rows import OutputError, describe_os_error

    ledger.clear()
    command = "oilwatch"
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        command = f"oilwatch {args.command}"
        check_outputs(args)
        return int(args.func(args) or 0)
    except OutputError as error:
        print(f"{command}: error: {error}; {ledger.kept()}", file=sys.stderr)
        return 2
    except InputError as error:
        print(f"{command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as stop:
        print(f"{command}: interrupted ({interrupts.signal_name(stop)}); {ledger.kept()}", file=sys.stderr)
        return interrupts.exit_code(stop)
    except OSError as error:
        where = "" if error.filename is None else f"cannot use {error.filename}: "
        print(f"{command}: error: {where}{describe_os_error(error)}; {ledger.kept()}", file=sys.stderr)
        return 2


def console_main() -> None:
    """The console script: SIGINT and SIGTERM handled first (:mod:`oilwatch.outputs.interrupts`; the
    modules imported before this line take a few milliseconds), then :func:`main`, then a normal
    interpreter exit, during which both are ignored (the command has finished and set its exit code).

    oilwatch's FMUs carry their own loader (``oilwatch/cosim/native/fmi2_loader.c``), which fixes
    pythonfmu 0.7's double release of its interpreter guard at process exit (PythonFMU issues #228,
    #229: "free(): corrupted unsorted chunks"), so the process may finalize normally after a run.
    """
    from oilwatch.outputs import interrupts

    interrupts.install()
    interrupts.ignore_at_exit()
    code = main()
    if code in (128 + signal.SIGINT, 128 + signal.SIGTERM):
        # a signal may have cut a numba compilation short: its half-built llvmlite objects fail in their
        # finalizers at interpreter exit, which would print tracebacks after the one-line message
        sys.unraisablehook = _ignore_unraisable
    sys.exit(code)


def _ignore_unraisable(unraisable) -> None:
    """Drop an exception raised in a finalizer (after an interrupted command has said what it kept)."""


if __name__ == "__main__":
    console_main()
