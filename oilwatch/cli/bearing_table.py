"""``oilwatch bearing-table``: the bearing coefficient table over supply flowrate.

Computes the flooded threshold q_t (groove full at zero gauge pressure), then the equilibrium and
the eight coefficients at ``--points`` flowrates evenly spread between the machine file's table
fractions of q_t (paper: 7 points, 50 % to 150 %), and writes them with units and provenance as
JSON, by default next to the machine file as
``tables/<machine stem>_bearing_<speed>hz[_synchronous].json``, where
``oilwatch.models.system`` looks for it (the bundled turbine: into the user cache, $OILWATCH_CACHE/tables,
never into the installed package; its committed models/tables/turbine_bearing_75hz*.json were made with
``--out``). A machine whose bearings differ gets one table per distinct bearing geometry,
``tables/<machine stem>_bearing<N>_<speed>hz[_synchronous].json`` for the first bearing N of that
geometry at its static load (``--bearing N``: that one only). ``--coefficients`` (default: the machine
file's ``bearings.dynamic_coefficients``, "synchronous" for the turbine) chooses K, C at whirl frequency
= spin speed (the transient film's small-signal response, ``oilwatch.models.bearing.dynamic``; file
suffix ``_synchronous``) or the quasi-static ones (no suffix).
Commands that need a missing table (``run``, ``demo``, ``orbits``, ...) compute it the same way.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from .bearing import add_common_arguments, machine_setup
from .machine_option import (
    TABLE_BEARING_HELP,
    add_bearing_option,
    add_coefficients_option,
    bearing_indices,
    compute_flowrate_table,
)
from .outputs import output_file


def register(subparsers) -> None:
    """Add the ``bearing-table`` subcommand."""
    parser = subparsers.add_parser(
        "bearing-table",
        help="compute the bearing coefficient table over supply flowrate",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_common_arguments(parser)
    parser.add_argument("--points", type=int, default=7, help="number of flowrates (>= 2)")
    parser.add_argument(
        "--out", help="output JSON file; default <machine dir>/tables/<stem>_bearing_<f>hz.json"
    )
    add_coefficients_option(parser, "the file name follows: ..._<f>hz_synchronous.json")
    parser.add_argument("--plot", metavar="FILE", help="also draw the table against flowrate")
    add_bearing_option(parser, *TABLE_BEARING_HELP)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(func=run)


def run(args) -> int:
    """Compute, write and optionally plot the table (one per distinct bearing geometry)."""
    from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S
    from oilwatch.models.machine import load_machine
    from oilwatch.models.validation import InputError

    if args.points < 2:
        raise InputError(f"--points must be >= 2, got {args.points}")
    single = next((f"--{k.replace('_', '-')}" for k in ("out", "plot", "load_n") if getattr(args, k)), None)
    for index in bearing_indices(load_machine(args.machine), args.bearing, single):
        setup = machine_setup(args, index)
        speed = setup["speed_hz"]
        out, table, q_t = compute_flowrate_table(
            setup["machine"],
            speed,
            points=args.points,
            load_n=setup["load_n"],
            mesh=setup["mesh"],
            out=Path(args.out) if args.out else None,
            progress=not args.quiet,
            command=command_line(args, setup["machine"], index),
            coefficients=args.coefficients,
            bearing_index=index,
        )
        written = f"{args.points} points written to {out}"
        print(f"q_t = {q_t * ML_MIN_PER_M3_S:.2f} ml/min at {speed:g} Hz; {written}", file=sys.stderr)
        if args.plot:
            plot_table(table, q_t, args.plot)
    return 0


def command_line(args, machine, bearing_index: int) -> str:
    """The command that reproduces the table of bearing ``bearing_index`` (from the parsed options, not
    sys.argv)."""
    from oilwatch.models.system.factory import bearing_arguments

    parts = ["oilwatch", "bearing-table"]
    for key in ("machine", "speed_hz", "load_n", "points", "coefficients", "out", "plot"):
        value = getattr(args, key)
        if value is not None:
            parts += [f"--{key.replace('_', '-')}", str(value)]
    if args.mesh is not None:
        parts += ["--mesh", *map(str, args.mesh)]
    return shlex.join(parts + bearing_arguments(machine, bearing_index))


def plot_table(table, q_t: float, path: str) -> None:
    """Eccentricity, attitude, K and C against flowrate, q_t marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S

    q_lo, q_hi = table.flowrate_range_m3_s
    fine = np.linspace(q_lo, q_hi, 200)
    curves = [table.evaluate(q) for q in fine]
    qf = fine * ML_MIN_PER_M3_S
    qn = table.flowrates_m3_s * ML_MIN_PER_M3_S
    fig, axes = plt.subplots(2, 2, figsize=(11, 8), sharex=True)
    ax = axes[0, 0]
    ax.plot(qn, table.eccentricity_ratio, "o-", label="eccentricity ratio")
    ax.set_ylabel("eccentricity ratio [-]")
    ax2 = ax.twinx()
    ax2.plot(qn, table.attitude_deg, "s--", color="tab:red", label="attitude")
    ax2.set_ylabel("attitude angle [deg]", color="tab:red")
    ax = axes[0, 1]
    ax.plot(qn, table.supply_pressure_pa / 1e5, "o-")
    ax.set_ylabel("groove pressure [bar]")
    for k, name in enumerate(("xx", "xy", "yx", "yy")):
        i, j = divmod(k, 2)
        axes[1, 0].plot(qf, [c.stiffness[i, j] for c in curves], label=f"K{name}")
        axes[1, 0].plot(qn, table.stiffness[:, i, j], "k.")
        style = "--" if name == "yx" else "-"  # Cyx = Cxy for the full-film squeeze treatment
        axes[1, 1].plot(qf, [c.damping[i, j] for c in curves], style, label=f"C{name}")
        axes[1, 1].plot(qn, table.damping[:, i, j], "k.")
    axes[1, 0].set_ylabel("stiffness [N/m]")
    axes[1, 1].set_ylabel("damping [N s/m]")
    for ax in axes.ravel():
        ax.axvline(q_t * ML_MIN_PER_M3_S, color="gray", lw=0.8, ls=":")
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("supply flowrate [ml/min] (dotted: flooded threshold q_t)")
        ax.legend(fontsize=8)
    fig.suptitle(f"bearing coefficients at {table.speed_hz:g} Hz, load {table.load_n:.1f} N")
    fig.tight_layout()
    fig.savefig(output_file("--plot", path), dpi=120)
    plt.close(fig)
