"""Accuracy of the committed dimensionless bearing table against direct solves (prints the figures).

    nice -n 10 python scripts/bearing_map_accuracy.py            # the issue's points and a spread of others
    python scripts/bearing_map_accuracy.py --quick               # only the four points the issue names
    python scripts/bearing_map_accuracy.py --coefficients quasi-static   # the other kind's table
    python scripts/bearing_map_accuracy.py --near-threshold --one-sided  # 0.95-1.05 of q_t, split at q_t

Points are off the table's nodes in Sommerfeld number; fractions of the flooded threshold 0.8 and 1.0 (the
issue's), and 0.55, 0.75, 0.95, 1.05, 1.25, 1.45 (off the flowrate nodes too). Also compares with the 1-D
table at 75 Hz of the same kind (models/tables/turbine_bearing_75hz[_synchronous].json) at flowrates between
its nodes. Default kind: the machine file's ``bearings.dynamic_coefficients``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.operating_accuracy import table_error
from oilwatch.models.bearing.operating_table import OperatingTable, operating_table_path
from oilwatch.models.bearing.table import CoefficientTable
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.factory import flowrate_table_path

ISSUE_POINTS = [(60.0, 0.07, 0.8), (60.0, 0.07, 1.0), (90.0, 0.12, 0.8), (90.0, 0.12, 1.0)]
SPREAD = [
    (48.0, 0.05, 0.55),
    (50.0, 0.17, 0.75),
    (66.0, 0.10, 1.25),
    (72.0, 0.09, 0.95),
    (80.0, 0.15, 1.05),
    (84.0, 0.06, 1.45),
    (100.0, 0.18, 0.75),
    (104.0, 0.06, 1.25),
]


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="only the issue's four points")
    parser.add_argument("--coefficients", choices=("synchronous", "quasi-static"), help="the table's kind")
    parser.add_argument(
        "--near-threshold",
        action="store_true",
        help="0.95, 0.99, 1, 1.01 and 1.05 of q_t at the issue's points",
    )
    parser.add_argument(
        "--one-sided", action="store_true", help="interpolate each side of the flooded threshold separately"
    )
    args = parser.parse_args()
    machine = load_machine()
    kind = args.coefficients or machine.dynamic_coefficients
    table = OperatingTable.load(operating_table_path(machine.source_path, kind))
    print(f"{kind} coefficients: {operating_table_path(machine.source_path, kind)}")
    mesh = Mesh(**table.metadata["mesh"])
    load = float(Rotor.from_machine(machine).bearing_static_loads_n[0])
    points = ISSUE_POINTS + ([] if args.quick else SPREAD)
    if args.near_threshold:
        points = [(v, m, f) for v, m in ((60.0, 0.07), (90.0, 0.12)) for f in (0.95, 0.99, 1.0, 1.01, 1.05)]
    print("speed_Hz  mu_Pa_s  q/q_t   S      e_direct  err_e %  err_K %max  err_C %max  solve_s")
    worst = np.zeros(3)
    for speed, mu, fraction in points:
        started = time.perf_counter()
        err = table_error(table, machine.bearing, speed, mu, load, fraction, mesh, args.one_sided)
        s = mu * speed * machine.bearing.length_m * 2 * machine.bearing.radius_m
        s *= (machine.bearing.radius_m / machine.bearing.clearance_m) ** 2 / load
        row = np.array([err.eccentricity_ratio, err.stiffness, err.damping]) * 100
        worst = np.maximum(worst, row)
        print(
            f"{speed:8.1f}  {mu:7.3f}  {fraction:5.2f}  {s:6.3f}  {err.direct_eccentricity_ratio:8.4f}  "
            f"{row[0]:7.3f}  {row[1]:10.3f}  {row[2]:10.3f}  {time.perf_counter() - started:7.1f}"
        )
    print(
        f"worst: eccentricity ratio {worst[0]:.3f} %, K {worst[1]:.3f} %, C {worst[2]:.3f} % "
        "of the largest entry"
    )
    one_d = CoefficientTable.load(flowrate_table_path(machine, machine.nominal_speed_hz, kind))
    q_lo, q_hi = one_d.flowrate_range_m3_s
    worst = np.zeros(3)
    for q in np.linspace(q_lo, q_hi, 41):
        ref = one_d.evaluate(q)
        point = table.evaluate(one_d.speed_hz, machine.bearing.viscosity_pa_s, one_d.load_n, q)
        k, c = point.coefficients.stiffness, point.coefficients.damping
        e_ref = np.hypot(*ref.eccentricity_m) / machine.bearing.clearance_m
        worst = np.maximum(
            worst,
            [
                abs(point.eccentricity_ratio - e_ref) / e_ref * 100,
                np.max(np.abs(k - ref.stiffness)) / np.max(np.abs(ref.stiffness)) * 100,
                np.max(np.abs(c - ref.damping)) / np.max(np.abs(ref.damping)) * 100,
            ],
        )
    print(
        f"against the 1-D 75 Hz table at 41 flowrates: eccentricity ratio {worst[0]:.3f} %, "
        f"K {worst[1]:.3f} %, C {worst[2]:.3f} % of the largest entry"
    )


if __name__ == "__main__":
    main()
