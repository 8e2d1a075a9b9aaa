"""``oilwatch speed-sweep``: bearing coefficients over spin speed at one supply flowrate."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from oilwatch.models.validation import InputError, require_positive

from .machine_option import TABLE_BEARING_HELP, add_bearing_option, add_machine_option, bearing_indices
from .modes import load_rotor


def register(subparsers) -> None:
    """Add the ``speed-sweep`` subcommand."""
    parser = subparsers.add_parser(
        "speed-sweep",
        help="bearing equilibrium, stiffness and damping over speed (for the stability analysis)",
        description=(
            "Compute each bearing's equilibrium and linearized coefficients at every speed of a sweep, at "
            "one supply flowrate (default: the machine's nominal), and write them with provenance to "
            "tables/<machine>_speed_sweep.json next to the machine file (the bundled turbine: the user "
            "cache, $OILWATCH_CACHE/tables). `oilwatch report` reads it. A machine whose bearings differ "
            "gets one sweep per distinct bearing geometry, tables/<machine>_bearing<N>_speed_sweep.json for "
            "the first bearing N of that geometry at its static load."
        ),
    )
    add_machine_option(parser)
    parser.add_argument(
        "--q-ml-min",
        type=float,
        default=None,
        help="supply flowrate [ml/min]; default: each bearing's nominal",
    )
    parser.add_argument("--speed-min-hz", type=float, default=30.0, help="lowest speed [Hz] (30)")
    parser.add_argument("--speed-max-hz", type=float, default=200.0, help="highest speed [Hz] (200)")
    parser.add_argument("--step-hz", type=float, default=5.0, help="speed step [Hz] (5)")
    parser.add_argument(
        "--squeeze",
        choices=("full-film", "everywhere"),
        default="full-film",
        help="squeeze-term model of the film (default full-film; see models.bearing.film)",
    )
    parser.add_argument("--out", default=None, help="output file (default: next to the machine file)")
    add_bearing_option(parser, *TABLE_BEARING_HELP)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Compute and write the sweep."""
    import numpy as np

    from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S
    from oilwatch.models.system.factory import new_table_path, speed_sweep_name
    from oilwatch.models.system.speed_sweep import compute_speed_sweep

    from .progress import progress_bar

    machine, rotor = load_rotor(args)
    low = require_positive("--speed-min-hz", args.speed_min_hz, "Hz")
    high = require_positive("--speed-max-hz", args.speed_max_hz, "Hz")
    step = require_positive("--step-hz", args.step_hz, "Hz")
    if high <= low:
        raise InputError(f"--speed-max-hz ({high:g}) must exceed --speed-min-hz ({low:g})")
    given = None if args.q_ml_min is None else require_positive("--q-ml-min", args.q_ml_min, "ml/min")
    speeds = np.arange(low, high + 0.5 * step, step)
    for index in bearing_indices(machine, args.bearing, "--out" if args.out else None):
        nominal = float(machine.lubrication.nominal_flowrates_m3_s[index]) * ML_MIN_PER_M3_S
        q_ml_min = nominal if given is None else given
        with progress_bar("speed sweep", "speed") as callback:
            sweep = compute_speed_sweep(
                machine.bearings[index],
                float(rotor.bearing_static_loads_n[index]),
                speeds,
                q_ml_min / ML_MIN_PER_M3_S,
                command="oilwatch " + shlex.join(sys.argv[1:]),
                progress=callback,
                squeeze=args.squeeze,
            )
        default = new_table_path(machine, speed_sweep_name(machine, args.squeeze, index))
        out_path = Path(args.out) if args.out else default
        out_path.parent.mkdir(parents=True, exist_ok=True)
        sweep.save(out_path)
        print(f"wrote {out_path} ({speeds.size} speeds, {q_ml_min:g} ml/min)", file=sys.stderr)
    return 0
