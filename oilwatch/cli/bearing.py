"""``oilwatch bearing``: equilibrium and linearized coefficients of one bearing at one supply.

Give the supply flowrate (``--q-ml-min``) or the groove pressure (``--supply-pressure-bar``; 0 gives
the flooded threshold q_t). Defaults come from the machine file (bundled turbine): bearing geometry,
nominal speed, the bearing's static load from the rotor model, the nominal supply pressure, the
nominal viscosity. ``--viscosity-pa-s`` or ``--oil-temperature-c`` (through the machine's oil, ASTM
D341) sets another viscosity. ``--from-table`` prints the dimensionless table's interpolated values at
the same point (``oilwatch bearing-map``) instead of a direct solve, with the same keys.
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from .machine_option import add_bearing_option, add_machine_option, add_mesh_option, mesh_option


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
    oil = parser.add_mutually_exclusive_group()
    oil.add_argument(
        "--viscosity-pa-s", type=float, help="film viscosity [Pa s]; default: the machine's nominal"
    )
    oil.add_argument(
        "--oil-temperature-c", type=float, help="oil temperature [degC]: viscosity from the machine's [oil]"
    )
    parser.add_argument(
        "--from-table",
        nargs="?",
        const="",
        metavar="FILE",
        help="interpolate the dimensionless table (default: the machine's, from `oilwatch bearing-map`) "
        "instead of solving; needs --q-ml-min",
    )
    add_bearing_option(parser, "solve its geometry at its load", "bearing 1")
    parser.add_argument("--json", action="store_true", help="print JSON on stdout")
    parser.set_defaults(func=run)


def operating_viscosity(args, machine) -> float:
    """The film viscosity [Pa s] from --viscosity-pa-s, --oil-temperature-c or the machine's nominal."""
    from oilwatch.models.validation import InputError, require_positive

    if args.viscosity_pa_s is not None:
        return require_positive("--viscosity-pa-s", args.viscosity_pa_s, "Pa s")
    if args.oil_temperature_c is not None:
        if machine.oil is None:
            raise InputError(f"--oil-temperature-c needs an [oil] section in {machine.source_path}")
        return machine.oil.dynamic_viscosity_pa_s(args.oil_temperature_c)
    return machine.bearings[0].viscosity_pa_s  # one oil: every bearing has the nominal viscosity


def add_common_arguments(parser: argparse.ArgumentParser) -> None:
    """Options shared with ``bearing-table``: machine file, speed, load, mesh."""
    add_machine_option(parser)
    parser.add_argument("--speed-hz", type=float, help="shaft speed [Hz]; default: nominal")
    parser.add_argument(
        "--load-n", type=float, help="static bearing load [N]; default: the bearing's, from the rotor model"
    )
    add_mesh_option(parser)


def machine_setup(args, bearing_index: int | None = None) -> dict:
    """Bearing, load [N], speed [Hz], mesh and nominal supply from the arguments and machine file, for
    bearing ``bearing_index`` (from 0; None: ``--bearing N``, else bearing 1)."""
    from oilwatch.models.machine import load_machine
    from oilwatch.models.rotor.assembly import Rotor
    from oilwatch.models.validation import require_positive

    from .machine_option import bearing_index as index_of

    machine = load_machine(args.machine)
    if bearing_index is None:
        bearing_index = 0 if args.bearing is None else index_of(machine, args.bearing)
    if args.load_n is None:
        loads = Rotor.from_machine(machine).bearing_static_loads_n
        load = float(loads[bearing_index])
    else:
        load = require_positive("--load-n", args.load_n, "N")
    speed = machine.nominal_speed_hz if args.speed_hz is None else args.speed_hz
    require_positive("--speed-hz", speed, "Hz")
    mesh = mesh_option(args)
    return {
        "machine": machine,
        "bearing_index": bearing_index,
        "bearing": machine.bearings[bearing_index],
        "load_n": load,
        "speed_hz": float(speed),
        "mesh": mesh,
        "lubrication": machine.lubrication,
    }


def run(args) -> int:
    """Solve and print one operating point."""
    import dataclasses

    from oilwatch.models.bearing.equilibrium import coefficients_at, static_equilibrium
    from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S, SupplyFlow, SupplyPressure
    from oilwatch.models.validation import require_non_negative, require_positive

    setup = machine_setup(args)
    viscosity = operating_viscosity(args, setup["machine"])
    setup["bearing"] = dataclasses.replace(setup["bearing"], viscosity_pa_s=viscosity)
    if args.from_table is not None:
        return print_result(from_table(args, setup), args, setup, "dimensionless table")
    if args.q_ml_min is not None:
        q = require_positive("--q-ml-min", args.q_ml_min, "ml/min (without oil there is no film)")
        supply = SupplyFlow(q / ML_MIN_PER_M3_S)
    else:
        bar = args.supply_pressure_bar
        lubrication = setup["lubrication"]
        if bar is None and math.isnan(lubrication.nominal_supply_pressure_pa):
            # the file gives the bearing's flowrate, no pressure
            supply = SupplyFlow(float(lubrication.nominal_flowrates_m3_s[setup["bearing_index"]]))
        else:
            if bar is None:
                bar = lubrication.nominal_supply_pressure_pa / 1e5
            supply = SupplyPressure(require_non_negative("--supply-pressure-bar", bar, "bar") * 1e5)
    bearing, load, speed, mesh = (setup[k] for k in ("bearing", "load_n", "speed_hz", "mesh"))
    eq = static_equilibrium(bearing, load, speed, supply, mesh)
    stiffness, damping = coefficients_at(bearing, eq, speed, supply, mesh, squeeze=args.squeeze)
    result = result_dict(
        eq.supply_flow_m3_s,
        eq.regime,
        eq.supply_pressure_pa,
        eq.eccentricity_ratio,
        eq.attitude_deg,
        eq.eccentricity_m,
        eq.side_leakage_m3_s,
        stiffness,
        damping,
    )
    return print_result(result, args, setup, f"mesh {mesh.n_circ} x {mesh.n_axial}, squeeze {args.squeeze}")


def result_dict(q, regime, pressure, ratio, attitude, e, leakage, stiffness, damping) -> dict:
    """The printed operating point (user units in the keys)."""
    from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S

    pairs = ("xx", "xy", "yx", "yy")
    return {
        "q_ml_min": q * ML_MIN_PER_M3_S,
        "regime": regime,
        "supply_pressure_pa": float(pressure),
        "eccentricity_ratio": float(ratio),
        "attitude_deg": float(attitude),
        "e_x_um": float(e[0] * 1e6),
        "e_y_um": float(e[1] * 1e6),
        "side_leakage_ml_min": leakage * ML_MIN_PER_M3_S,
        "K_N_per_m": dict(zip(pairs, map(float, np.ravel(stiffness)), strict=True)),
        "C_Ns_per_m": dict(zip(pairs, map(float, np.ravel(damping)), strict=True)),
    }


def from_table(args, setup) -> dict:
    """The dimensionless table's interpolated operating point (steady: side leakage = supply flowrate)."""
    from pathlib import Path

    from oilwatch.models.bearing.operating_table import OperatingTable, operating_table_path
    from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S
    from oilwatch.models.system.factory import geometry_number
    from oilwatch.models.validation import InputError, require_positive

    if args.q_ml_min is None:
        raise InputError("--from-table needs --q-ml-min (the table is over supply flowrate)")
    if args.squeeze != "full-film":
        raise InputError("--from-table holds the default squeeze model only (--squeeze full-film)")
    if args.mesh is not None:
        raise InputError("--from-table uses the table's own mesh: drop --mesh")
    machine = setup["machine"]
    number = geometry_number(machine, setup["bearing_index"])
    path = (
        Path(args.from_table)
        if args.from_table
        else operating_table_path(machine.source_path, bearing=number)
    )
    table = OperatingTable.load(path)
    table.check_geometry(setup["bearing"])
    q = require_positive("--q-ml-min", args.q_ml_min, "ml/min") / ML_MIN_PER_M3_S
    point = table.evaluate(setup["speed_hz"], setup["bearing"].viscosity_pa_s, setup["load_n"], q)
    k = point.coefficients
    return result_dict(
        q,
        point.regime,
        point.supply_pressure_pa,
        point.eccentricity_ratio,
        point.attitude_deg,
        point.eccentricity_m,
        q,
        k.stiffness,
        k.damping,
    )


def print_result(result: dict, args, setup, how: str) -> int:
    """Print ``result`` as JSON or as a readable block."""
    if args.json:
        print(json.dumps(result, indent=1))
        return 0
    speed, load, mu = setup["speed_hz"], setup["load_n"], setup["bearing"].viscosity_pa_s
    angle = math.degrees(setup["bearing"].load_angle_rad)
    along = "" if angle == 180.0 else f" along {angle:g} deg (the attitude is from it)"
    k, c = result["K_N_per_m"], result["C_Ns_per_m"]
    print(
        f"bearing at {speed:g} Hz, viscosity {mu:.4g} Pa s, load {load:.1f} N{along}, {how}\n"
        f"  supply flowrate      {result['q_ml_min']:10.2f} ml/min ({result['regime']})\n"
        f"  groove pressure      {result['supply_pressure_pa'] / 1e5:10.4f} bar\n"
        f"  side leakage         {result['side_leakage_ml_min']:10.2f} ml/min\n"
        f"  eccentricity ratio   {result['eccentricity_ratio']:10.4f}\n"
        f"  attitude angle       {result['attitude_deg']:10.2f} deg\n"
        f"  journal centre       x {result['e_x_um']:8.3f} um   y {result['e_y_um']:8.3f} um\n"
        f"  stiffness K [N/m]    xx {k['xx']:11.4e}  xy {k['xy']:11.4e}\n"
        f"                       yx {k['yx']:11.4e}  yy {k['yy']:11.4e}\n"
        f"  damping C [N s/m]    xx {c['xx']:11.4e}  xy {c['xy']:11.4e}\n"
        f"                       yx {c['yx']:11.4e}  yy {c['yy']:11.4e}"
    )
    return 0
