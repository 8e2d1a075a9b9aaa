"""``oilwatch orbits``: the steady unbalance orbits in both bearings as the flowrates fall (Fig. 5)."""

from __future__ import annotations

import argparse
import json
import sys

from .machine_option import add_machine_option
from .outputs import output_file


def register(subparsers) -> None:
    """Add the ``orbits`` subcommand."""
    parser = subparsers.add_parser(
        "orbits",
        help="steady orbits in both bearings for falling flowrates (the paper's Fig. 5)",
        description=(
            "Plot the steady unbalance orbit of the shaft in each bearing for q1 = q2 = each given "
            "percentage of the nominal flowrate."
        ),
    )
    add_machine_option(parser)
    parser.add_argument(
        "--q-pct",
        type=float,
        nargs="+",
        default=[100, 95, 90, 85, 80, 75],
        help="flowrates as %% of nominal (default: 100 95 90 85 80 75)",
    )
    parser.add_argument("--out", default="orbits.png", help="output image (default: orbits.png)")
    parser.add_argument("--json", action="store_true", help="also print the orbit figures as JSON")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Compute the orbits and draw them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from oilwatch.models.system.factory import build_system
    from oilwatch.models.system.sensitivity import steady_orbit

    from .machine_option import ensure_flowrate_tables, load_machine_option

    machine = load_machine_option(args)
    ensure_flowrate_tables(machine, [machine.nominal_speed_hz], "orbits")
    system = build_system(machine, reduced=False)
    nominal = machine.lubrication.nominal_flowrates_m3_s  # each bearing's percentage of its own nominal
    figure, axes = plt.subplots(1, 2, figsize=(11, 5.2))
    colours = plt.cm.viridis(np.linspace(0.0, 0.9, len(args.q_pct)))
    figures = []
    for pct, colour in zip(args.q_pct, colours, strict=True):
        q1, q2 = (float(q) * pct / 100.0 for q in nominal)
        orbit = steady_orbit(system, (q1, q2))
        trace = orbit.trace() * 1e6
        for b, axis in enumerate(axes):
            axis.plot(trace[b, :, 0], trace[b, :, 1], color=colour, label=f"{pct:g} %")
            axis.plot(*(orbit.centre_m[b] * 1e6), "+", color=colour)
        figures.append(
            {
                "q_pct": pct,
                "eccentricity_um": (orbit.eccentricity_m * 1e6).tolist(),
                "centre_um": (orbit.centre_m * 1e6).tolist(),
                "amplitude_x_um": (np.abs(orbit.amplitude_m[:, 0]) * 1e6).tolist(),
                "amplitude_y_um": (np.abs(orbit.amplitude_m[:, 1]) * 1e6).tolist(),
            }
        )
    for b, (axis, node) in enumerate(zip(axes, system.rotor.bearing_nodes, strict=True)):
        axis.set_title(f"bearing {b + 1} (node {node})")
        axis.set_xlabel("x [um]")
        axis.set_ylabel("y [um]")
        axis.set_aspect("equal", adjustable="datalim")
        axis.grid(True, alpha=0.3)
        axis.legend(title="q1 = q2", fontsize=8)
    figure.suptitle(f"Steady unbalance orbits at {system.speed_hz:g} Hz (+: orbit centre)")
    figure.tight_layout()
    figure.savefig(output_file("--out", args.out), dpi=120)
    print(f"wrote {args.out}", file=sys.stderr)
    if args.json:
        print(json.dumps({"speed_hz": system.speed_hz, "orbits": figures}, indent=1))
    return 0
