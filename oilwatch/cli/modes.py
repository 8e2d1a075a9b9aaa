"""``oilwatch modes``: damped natural frequencies, log decrements and whirl at one spin speed.

Also holds the helpers the rotor subcommands share: ``--machine``/bearing options, reading the
machine, and :func:`bearings_for`, the one place that decides which bearings the rotor sits on.
"""

from __future__ import annotations

import argparse
import json

DEFAULT_BEARING_STIFFNESS_N_M = 1.0e8
DEFAULT_BEARING_DAMPING_N_S_M = 1.0e4


def add_machine_option(parser: argparse.ArgumentParser) -> None:
    """``--machine FILE`` (default: the bundled generic turbine)."""
    parser.add_argument(
        "--machine",
        metavar="FILE",
        default=None,
        help="machine file (TOML, units in the keys); default: the bundled generic turbine",
    )


def add_bearing_options(parser: argparse.ArgumentParser) -> None:
    """``--bearing-k`` and ``--bearing-c``: isotropic linear bearings at every bearing node."""
    parser.add_argument(
        "--bearing-k",
        type=float,
        default=None,
        metavar="N_PER_M",
        help="isotropic linear bearing stiffness kxx = kyy at each bearing [N/m] "
        f"(default {DEFAULT_BEARING_STIFFNESS_N_M:g})",
    )
    parser.add_argument(
        "--bearing-c",
        type=float,
        default=None,
        metavar="N_S_PER_M",
        help="isotropic linear bearing damping cxx = cyy at each bearing [N s/m] "
        f"(default {DEFAULT_BEARING_DAMPING_N_S_M:g})",
    )


def load_rotor(args: argparse.Namespace):
    """The machine and its assembled rotor from ``--machine`` (InputError on a bad file)."""
    from models.machine import load_machine
    from models.rotor.assembly import Rotor

    machine = load_machine(args.machine)
    return machine, Rotor.from_machine(machine)


def bearings_for(args: argparse.Namespace, machine, rotor):
    """The bearings the rotor sits on, as a callable speed_hz -> list of LinearBearing, and a
    JSON-ready description of them.

    Today: isotropic linear bearings (kxx = kyy = k, cxx = cyy = c, no cross terms) at every
    bearing node of the machine.
    """
    from models.rotor.supports import isotropic_bearings
    from models.validation import require_non_negative

    k = DEFAULT_BEARING_STIFFNESS_N_M if args.bearing_k is None else args.bearing_k
    c = DEFAULT_BEARING_DAMPING_N_S_M if args.bearing_c is None else args.bearing_c
    k = require_non_negative("--bearing-k", k, "N/m")
    c = require_non_negative("--bearing-c", c, "N s/m")
    bearings = isotropic_bearings(rotor.bearing_nodes, k, c)
    description = {
        "model": "linear isotropic",
        "nodes": list(rotor.bearing_nodes),
        "stiffness_n_m": k,
        "damping_n_s_m": c,
    }
    return (lambda speed_hz: bearings), description


def require_count(name: str, value: int, minimum: int) -> int:
    """An integer option >= minimum, else InputError."""
    from models.validation import InputError

    if value < minimum:
        raise InputError(f"{name} must be an integer >= {minimum}, got {value}")
    return value


def register(subparsers) -> None:
    """Add the ``modes`` subcommand."""
    parser = subparsers.add_parser(
        "modes",
        help="damped natural frequencies, log decrements and whirl at one speed",
        description="Damped lateral modes of the rotor on its bearings at one spin speed, sorted "
        "by frequency. Log decrement < 0 means the mode is unstable.",
    )
    parser.add_argument(
        "--speed-hz",
        type=float,
        default=None,
        help="spin speed [Hz] (default: the machine's nominal speed)",
    )
    add_bearing_options(parser)
    parser.add_argument("--n-modes", type=int, default=8, help="number of lowest modes to list (default 8)")
    add_machine_option(parser)
    parser.add_argument("--json", action="store_true", help="print JSON on stdout")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Compute and print the modes; returns the exit code."""
    from models.rotor.modal import damped_modes
    from models.validation import require_non_negative

    machine, rotor = load_rotor(args)
    speed_hz = machine.nominal_speed_hz if args.speed_hz is None else args.speed_hz
    speed_hz = require_non_negative("--speed-hz", speed_hz, "Hz")
    n_modes = require_count("--n-modes", args.n_modes, 1)
    bearings_at, description = bearings_for(args, machine, rotor)
    modes = damped_modes(rotor, speed_hz, bearings_at, n_modes)
    if args.json:
        payload = {
            "speed_hz": speed_hz,
            "machine": str(machine.source_path),
            "bearings": description,
            "modes": [
                {
                    "frequency_hz": m.frequency_hz,
                    "log_decrement": m.log_decrement,
                    "damping_ratio": m.damping_ratio,
                    "whirl": m.whirl,
                }
                for m in modes
            ],
        }
        print(json.dumps(payload, indent=2))
        return 0
    print(f"{machine.name}: damped lateral modes at {speed_hz:g} Hz ({speed_hz * 60:g} rpm)")
    print(
        f"bearings: {description['model']} at nodes {description['nodes']}, "
        f"k = {description['stiffness_n_m']:g} N/m, c = {description['damping_n_s_m']:g} N s/m"
    )
    print(f"{'mode':>4}  {'frequency [Hz]':>14}  {'log decrement':>13}  {'zeta [%]':>8}  whirl")
    for i, m in enumerate(modes, start=1):
        flag = "  UNSTABLE" if m.log_decrement < 0.0 else ""
        print(
            f"{i:>4}  {m.frequency_hz:>14.2f}  {m.log_decrement:>13.4f}  "
            f"{100.0 * m.damping_ratio:>8.3f}  {m.whirl}{flag}"
        )
    return 0
