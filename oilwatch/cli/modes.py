"""``oilwatch modes``: damped natural frequencies, log decrements and whirl at one spin speed.

Also holds the helpers the rotor subcommands share: bearing options, reading the machine (``--machine``
is :mod:`oilwatch.cli.machine_option`'s), and :func:`bearings_for`, the one place that decides which
bearings the rotor sits on.
"""

from __future__ import annotations

import argparse
import json

from .machine_option import add_machine_option

DEFAULT_BEARING_STIFFNESS_N_M = 1.0e8
DEFAULT_BEARING_DAMPING_N_S_M = 1.0e4


def add_bearing_options(parser: argparse.ArgumentParser) -> None:
    """``--q1-pct``/``--q2-pct`` (fluid-film bearings, the default) or ``--bearing-k``/``--bearing-c``
    (isotropic linear bearings at every bearing node)."""
    for b in (1, 2):
        parser.add_argument(
            f"--q{b}-pct",
            type=float,
            default=100.0,
            metavar="PCT",
            help=f"supply flowrate of bearing {b}, %% of its nominal (fluid-film bearings; default 100)",
        )
    parser.add_argument(
        "--bearing-k",
        type=float,
        default=None,
        metavar="N_PER_M",
        help="use isotropic linear bearings instead of the fluid film: stiffness kxx = kyy [N/m] "
        f"(default with --bearing-c: {DEFAULT_BEARING_STIFFNESS_N_M:g})",
    )
    parser.add_argument(
        "--bearing-c",
        type=float,
        default=None,
        metavar="N_S_PER_M",
        help="use isotropic linear bearings instead of the fluid film: damping cxx = cyy [N s/m] "
        f"(default with --bearing-k: {DEFAULT_BEARING_DAMPING_N_S_M:g})",
    )


def load_rotor(args: argparse.Namespace):
    """The machine and its assembled rotor from ``--machine`` (InputError on a bad file)."""
    from oilwatch.models.machine import load_machine
    from oilwatch.models.rotor.assembly import Rotor

    machine = load_machine(args.machine)
    return machine, Rotor.from_machine(machine)


def uses_fluid_film(args: argparse.Namespace) -> bool:
    """True unless ``--bearing-k`` or ``--bearing-c`` asks for linear isotropic bearings."""
    return args.bearing_k is None and args.bearing_c is None


def bearings_for(args: argparse.Namespace, machine, rotor, over_speed: bool = False):
    """The bearings the rotor sits on, as a callable speed_hz -> list of LinearBearing, and a
    JSON-ready description of them.

    Default: the fluid-film bearings at ``--q1-pct``/``--q2-pct`` of the nominal flowrate (from the
    flowrate table at the speed, or the speed sweep; ``over_speed`` always uses the sweep, so a
    Campbell diagram has one source). With ``--bearing-k``/``--bearing-c``: isotropic linear bearings
    (kxx = kyy = k, cxx = cyy = c, no cross terms) at every bearing node.
    """
    from oilwatch.models.rotor.supports import isotropic_bearings
    from oilwatch.models.system.supports import fluid_film_bearings, fluid_film_bearings_over_speed
    from oilwatch.models.validation import InputError, require_non_negative, require_positive

    if uses_fluid_film(args):
        pct = [require_positive(f"--q{b}-pct", getattr(args, f"q{b}_pct"), "%") for b in (1, 2)]
        nominal = machine.lubrication.nominal_flowrates_m3_s  # each --q<b>-pct of its own bearing's
        flowrates = [float(nominal[b]) * p / 100.0 for b, p in enumerate(pct)]
        description = {
            "model": "fluid film (p-theta tables, linearized)",
            "nodes": list(rotor.bearing_nodes),
            "q_pct": pct,
            "q_ml_min": [q * 6e7 for q in flowrates],
        }
        if over_speed:
            if pct != [100.0, 100.0]:
                raise InputError(
                    "--q1-pct/--q2-pct: a Campbell diagram with fluid-film bearings uses the speed sweep, "
                    "which holds the nominal flowrate (100 %) only"
                )
            return fluid_film_bearings_over_speed(machine, rotor), description
        return (lambda speed_hz: fluid_film_bearings(machine, rotor, speed_hz, flowrates)), description
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


def describe_bearings(description: dict) -> str:
    """One line saying which bearings were used."""
    where = f"{description['model']} at nodes {description['nodes']}"
    if "q_ml_min" in description:
        flows = ", ".join(f"{q:.1f}" for q in description["q_ml_min"])
        return f"{where}, supply flowrates {flows} ml/min"
    return f"{where}, k = {description['stiffness_n_m']:g} N/m, c = {description['damping_n_s_m']:g} N s/m"


def require_count(name: str, value: int, minimum: int) -> int:
    """An integer option >= minimum, else InputError."""
    from oilwatch.models.validation import InputError

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
    from oilwatch.models.rotor.modal import damped_modes
    from oilwatch.models.validation import require_non_negative

    machine, rotor = load_rotor(args)
    speed_hz = machine.nominal_speed_hz if args.speed_hz is None else args.speed_hz
    speed_hz = require_non_negative("--speed-hz", speed_hz, "Hz")
    n_modes = require_count("--n-modes", args.n_modes, 1)
    if uses_fluid_film(args) and speed_hz > 0.0:
        from oilwatch.models.system.factory import flowrate_tables_exist, speed_sweep_path

        from .machine_option import ensure_flowrate_tables

        sweeps = all(speed_sweep_path(machine, bearing_index=i).exists() for i in machine.distinct_geometries)
        if not (flowrate_tables_exist(machine, speed_hz, "quasi-static") or sweeps):
            ensure_flowrate_tables(machine, [speed_hz], "modes")
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
    print(f"bearings: {describe_bearings(description)}")
    print(f"{'mode':>4}  {'frequency [Hz]':>14}  {'log decrement':>13}  {'zeta [%]':>8}  whirl")
    for i, m in enumerate(modes, start=1):
        flag = "  UNSTABLE" if m.log_decrement < 0.0 else ""
        print(
            f"{i:>4}  {m.frequency_hz:>14.2f}  {m.log_decrement:>13.4f}  "
            f"{100.0 * m.damping_ratio:>8.3f}  {m.whirl}{flag}"
        )
    return 0
