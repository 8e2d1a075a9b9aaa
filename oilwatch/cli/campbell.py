"""``oilwatch campbell``: damped natural frequencies and log decrements over spin speed."""

from __future__ import annotations

import argparse
import json
import sys

from .machine_option import add_machine_option
from .modes import (
    add_bearing_options,
    bearings_for,
    load_rotor,
    require_count,
    uses_fluid_film,
)
from .outputs import output_file

LOG_DECREMENT_AXIS_MAX = 2.0


def register(subparsers) -> None:
    """Add the ``campbell`` subcommand."""
    parser = subparsers.add_parser(
        "campbell",
        help="Campbell diagram (frequencies and log decrements over speed) with the 1x line",
        description="Damped lateral modes over a speed range, plotted with the synchronous (1x) "
        "line; forward-whirl crossings of the 1x line are the critical speeds.",
    )
    parser.add_argument(
        "--speed-min-hz",
        type=float,
        default=None,
        help="lowest speed [Hz] (default: 0, or the speed sweep's lowest speed with fluid-film bearings)",
    )
    parser.add_argument(
        "--speed-max-hz",
        type=float,
        default=None,
        help="highest speed [Hz] (default: 1.6 x the nominal speed)",
    )
    parser.add_argument("--n-speeds", type=int, default=50, help="number of speeds (default 50)")
    parser.add_argument("--n-modes", type=int, default=8, help="modes per speed (default 8)")
    add_bearing_options(parser)
    add_machine_option(parser)
    parser.add_argument("--out", default="campbell.png", help="plot file (PNG/PDF/SVG; default campbell.png)")
    parser.add_argument(
        "--json", action="store_true", help="print the diagram as JSON on stdout (still plots)"
    )
    parser.set_defaults(func=run)


def plot_campbell(diagram, out_path: str, title: str) -> None:
    """Frequencies (forward solid, backward dashed) with the 1x line, and log decrements."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    speeds = diagram.speeds_hz
    fig, (ax_f, ax_d) = plt.subplots(2, 1, figsize=(8, 8), sharex=True, height_ratios=[2, 1])
    for j in range(diagram.frequencies_hz.shape[1]):
        for forward, style, label in ((True, "o", "forward"), (False, "x", "backward")):
            mask = diagram.forward[:, j] == forward
            kwargs = {"label": label} if j == 0 else {}
            color = "tab:blue" if forward else "tab:red"
            ax_f.plot(speeds[mask], diagram.frequencies_hz[mask, j], style, ms=3, color=color, **kwargs)
            ax_d.plot(speeds[mask], diagram.log_decrements[mask, j], style, ms=3, color=color)
    ax_f.plot(speeds, speeds, "k--", lw=1, label="1x")
    for critical in diagram.critical_speeds_hz():
        ax_f.plot(critical, critical, "ks", mfc="none", ms=8)
        ax_f.annotate(f"{critical:.1f} Hz", (critical, critical), textcoords="offset points", xytext=(6, -12))
    top = np.nanmax(diagram.frequencies_hz)
    ax_f.set_ylim(0.0, 1.05 * max(top, speeds.max()))
    ax_f.set_ylabel("damped natural frequency [Hz]")
    ax_f.set_title(title)
    ax_f.legend(loc="upper left")
    ax_f.grid(alpha=0.3)
    ax_d.axhline(0.0, color="k", lw=1)
    # Heavily damped film modes (log decrements of tens) would flatten the region where stability is
    # decided, so the axis stops at LOG_DECREMENT_AXIS_MAX and says what it leaves out.
    finite = diagram.log_decrements[np.isfinite(diagram.log_decrements)]
    if finite.size and finite.max() > LOG_DECREMENT_AXIS_MAX:
        ax_d.set_ylim(min(-0.1, 1.1 * finite.min()), LOG_DECREMENT_AXIS_MAX)
        ax_d.text(
            0.01,
            0.95,
            f"modes with log decrement > {LOG_DECREMENT_AXIS_MAX:g} off scale",
            transform=ax_d.transAxes,
            va="top",
            fontsize=8,
        )
    ax_d.set_ylabel("log decrement [-]")
    ax_d.set_xlabel("spin speed [Hz]")
    ax_d.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(output_file("--out", out_path), dpi=120)
    plt.close(fig)


def run(args: argparse.Namespace) -> int:
    """Compute, plot and summarize the Campbell diagram; returns the exit code."""
    import numpy as np

    from oilwatch.models.rotor.modal import campbell_diagram
    from oilwatch.models.validation import InputError, require_non_negative

    from .progress import progress_bar

    machine, rotor = load_rotor(args)
    bearings_at, description = bearings_for(args, machine, rotor, over_speed=True)
    low = args.speed_min_hz
    if low is None:
        low = _sweep_start_hz(machine, rotor) if uses_fluid_film(args) else 0.0
    low = require_non_negative("--speed-min-hz", low, "Hz")
    high = 1.6 * machine.nominal_speed_hz if args.speed_max_hz is None else args.speed_max_hz
    high = require_non_negative("--speed-max-hz", high, "Hz")
    if high <= low:
        raise InputError(f"--speed-max-hz must exceed --speed-min-hz ({low:g} Hz), got {high:g}")
    n_speeds = require_count("--n-speeds", args.n_speeds, 2)
    n_modes = require_count("--n-modes", args.n_modes, 1)
    with progress_bar("Campbell", "speed", sys.stderr.isatty()) as callback:
        diagram = campbell_diagram(
            rotor,
            np.linspace(low, high, n_speeds),
            bearings_at,
            n_modes,
            progress=callback,
        )
    title = f"{machine.name}\nbearings: {description['model']}"
    plot_campbell(diagram, args.out, title)
    critical = diagram.critical_speeds_hz()
    unstable = diagram.speeds_hz[np.any(diagram.log_decrements < 0.0, axis=1)]
    onset = float(unstable[0]) if unstable.size else None
    if args.json:
        payload = {
            "speeds_hz": diagram.speeds_hz.tolist(),
            "frequencies_hz": np.where(
                np.isnan(diagram.frequencies_hz), None, diagram.frequencies_hz
            ).tolist(),
            "log_decrements": np.where(
                np.isnan(diagram.log_decrements), None, diagram.log_decrements
            ).tolist(),
            "whirl": np.where(diagram.forward, "forward", "backward").tolist(),
            "critical_speeds_hz": critical,
            "first_unstable_speed_hz": onset,
            "bearings": description,
            "plot": args.out,
        }
        print(json.dumps(payload))
        return 0
    print(f"{machine.name}: Campbell diagram, {n_speeds} speeds from {low:g} to {high:g} Hz")
    print(f"critical speeds (forward whirl on 1x): {', '.join(f'{c:.2f} Hz' for c in critical) or 'none'}")
    print(
        "lowest log decrement: "
        f"{np.nanmin(diagram.log_decrements):.4f}"
        + (f" (first unstable speed {onset:g} Hz)" if onset is not None else " (stable)")
    )
    print(f"plot written to {args.out}")
    return 0


def _sweep_start_hz(machine, rotor) -> float:
    """Lowest speed of the machine's speed sweep [Hz]."""
    from oilwatch.models.system.factory import load_speed_sweeps

    return float(load_speed_sweeps(machine, rotor)[0].speeds_hz[0])
