"""``oilwatch bearing``: equilibrium and linearized coefficients of one bearing at one supply.

Give the supply flowrate (``--q-ml-min``) or the groove pressure (``--supply-pressure-bar``; 0 gives
the flooded threshold q_t). Defaults come from the machine file (bundled turbine): bearing geometry,
nominal speed, the bearing's static load from the rotor model, the nominal supply pressure.
"""

from __future__ import annotations

import argparse
import json
import math

from .machine_option import add_machine_option


def register(subparsers) -> None:
    """Add the ``bearing`` subcommand."""
    parser = subparsers.add_parser(
        "bearing",
        help="bearing equilibrium, stiffness and damping at one supply flowrate or pressure",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    supply = parser.add_mutually_exclusive_group()
    supply.add_argument("--q-ml-min", type=float, help="supply flowrate [ml/min]")
    supply.add_argument(
        "--supply-pressure-bar",
        type=float,
        help="groove (supply) gauge pressure [bar]; default: the machine's nominal",
    )
    add_common_arguments(parser)
    parser.add_argument(
        "--squeeze",
        choices=("full-film", "everywhere"),
        default="full-film",
        help="squeeze-term treatment for the damping (see models.bearing.film); default full-film",
    )
    parser.add_argument("--json", action="store_true", help="print JSON on stdout")
    parser.set_defaults(func=run)


def add_common_arguments(parser: argparse.ArgumentParser) -> None:
    """Options shared with ``bearing-table``: machine file, speed, load, mesh."""
    add_machine_option(parser)
    parser.add_argument("--speed-hz", type=float, help="shaft speed [Hz]; default: nominal")
    parser.add_argument("--load-n", type=float, help="static bearing load [N]; default: from the rotor model")
    parser.add_argument(
        "--mesh",
        type=int,
        nargs=2,
        metavar=("N_CIRC", "N_AXIAL"),
        help="finite volumes around x along the bearing; default: the production mesh",
    )


def machine_setup(args) -> dict:
    """Bearing, load [N], speed [Hz], mesh and nominal supply from the arguments and machine file."""
    from models.bearing.grid import PRODUCTION_MESH, Mesh
    from models.machine import load_machine
    from models.rotor.assembly import Rotor
    from models.validation import require_positive

    machine = load_machine(args.machine)
    if args.load_n is None:
        loads = Rotor.from_machine(machine).bearing_static_loads_n
        load = float(loads[0])
    else:
        load = require_positive("--load-n", args.load_n, "N")
    speed = machine.nominal_speed_hz if args.speed_hz is None else args.speed_hz
    require_positive("--speed-hz", speed, "Hz")
    mesh = PRODUCTION_MESH if args.mesh is None else Mesh(*args.mesh)
    return {
        "machine": machine,
        "bearing": machine.bearing,
        "load_n": load,
        "speed_hz": float(speed),
        "mesh": mesh,
        "lubrication": machine.lubrication,
    }


def run(args) -> int:
    """Solve and print one operating point."""
    from models.bearing.equilibrium import coefficients_at, static_equilibrium
    from models.bearing.supply import ML_MIN_PER_M3_S, SupplyFlow, SupplyPressure
    from models.validation import require_non_negative, require_positive

    setup = machine_setup(args)
    if args.q_ml_min is not None:
        q = require_positive("--q-ml-min", args.q_ml_min, "ml/min (without oil there is no film)")
        supply = SupplyFlow(q / ML_MIN_PER_M3_S)
    else:
        bar = args.supply_pressure_bar
        lubrication = setup["lubrication"]
        if bar is None and math.isnan(lubrication.nominal_supply_pressure_pa):
            supply = SupplyFlow(lubrication.nominal_flowrate_m3_s)  # the file gives a flowrate, no pressure
        else:
            if bar is None:
                bar = lubrication.nominal_supply_pressure_pa / 1e5
            supply = SupplyPressure(require_non_negative("--supply-pressure-bar", bar, "bar") * 1e5)
    bearing, load, speed, mesh = (setup[k] for k in ("bearing", "load_n", "speed_hz", "mesh"))
    eq = static_equilibrium(bearing, load, speed, supply, mesh)
    stiffness, damping = coefficients_at(bearing, eq, speed, supply, mesh, squeeze=args.squeeze)
    pairs = ("xx", "xy", "yx", "yy")
    result = {
        "q_ml_min": eq.supply_flow_m3_s * ML_MIN_PER_M3_S,
        "regime": eq.regime,
        "supply_pressure_pa": eq.supply_pressure_pa,
        "eccentricity_ratio": eq.eccentricity_ratio,
        "attitude_deg": eq.attitude_deg,
        "e_x_um": float(eq.eccentricity_m[0] * 1e6),
        "e_y_um": float(eq.eccentricity_m[1] * 1e6),
        "side_leakage_ml_min": eq.side_leakage_m3_s * ML_MIN_PER_M3_S,
        "K_N_per_m": dict(zip(pairs, map(float, stiffness.ravel()), strict=True)),
        "C_Ns_per_m": dict(zip(pairs, map(float, damping.ravel()), strict=True)),
    }
    if args.json:
        print(json.dumps(result, indent=1))
        return 0
    print(
        f"bearing at {speed:g} Hz, load {load:.1f} N, mesh {mesh.n_circ} x {mesh.n_axial}, "
        f"squeeze {args.squeeze}\n"
        f"  supply flowrate      {result['q_ml_min']:10.2f} ml/min ({eq.regime})\n"
        f"  groove pressure      {eq.supply_pressure_pa / 1e5:10.4f} bar\n"
        f"  side leakage         {result['side_leakage_ml_min']:10.2f} ml/min\n"
        f"  eccentricity ratio   {eq.eccentricity_ratio:10.4f}\n"
        f"  attitude angle       {eq.attitude_deg:10.2f} deg\n"
        f"  journal centre       x {result['e_x_um']:8.3f} um   y {result['e_y_um']:8.3f} um\n"
        f"  stiffness K [N/m]    xx {stiffness[0, 0]:11.4e}  xy {stiffness[0, 1]:11.4e}\n"
        f"                       yx {stiffness[1, 0]:11.4e}  yy {stiffness[1, 1]:11.4e}\n"
        f"  damping C [N s/m]    xx {damping[0, 0]:11.4e}  xy {damping[0, 1]:11.4e}\n"
        f"                       yx {damping[1, 0]:11.4e}  yy {damping[1, 1]:11.4e}"
    )
    return 0
