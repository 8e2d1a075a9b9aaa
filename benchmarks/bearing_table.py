"""Wall time of the full coefficient table (q_t plus 7 flowrates) at the production mesh.

Times exactly what ``oilwatch bearing-table`` computes (no file written), prints the median over
repeats, the time per flowrate and the ratio to the 60 s target. Run by hand:

    OPENBLAS_NUM_THREADS=1 python benchmarks/bearing_table.py [--repeats 3] [--speed-hz 75]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from oilwatch.models.bearing.grid import PRODUCTION_MESH
from oilwatch.models.bearing.table import compute_table, flooded_threshold
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor

TARGET_S = 60.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--points", type=int, default=7)
    parser.add_argument("--speed-hz", type=float, default=None, help="default: the machine's nominal speed")
    args = parser.parse_args()
    machine = load_machine()
    bearing = machine.bearing
    load = float(Rotor.from_machine(machine).bearing_static_loads_n[0])
    if args.speed_hz is None:
        args.speed_hz = machine.nominal_speed_hz
    times, threshold_times = [], []
    for _ in range(args.repeats):
        start = time.perf_counter()
        q_t, _ = flooded_threshold(bearing, load, args.speed_hz, PRODUCTION_MESH)
        threshold_times.append(time.perf_counter() - start)
        compute_table(
            bearing,
            load,
            args.speed_hz,
            q_t * np.linspace(0.5, 1.5, args.points),
            PRODUCTION_MESH,
        )
        times.append(time.perf_counter() - start)
    median = statistics.median(times)
    print(
        f"mesh {PRODUCTION_MESH.n_circ} x {PRODUCTION_MESH.n_axial}, {args.points} flowrates "
        f"at {args.speed_hz:g} Hz, {args.repeats} repeats, one process"
    )
    print(f"  q_t (equilibrium at zero supply pressure): {statistics.median(threshold_times):6.2f} s")
    print(f"  whole table (median):                      {median:6.2f} s")
    print(f"  per flowrate:                              {median / args.points:6.2f} s")
    print(f"  ratio to the {TARGET_S:.0f} s target:                 {median / TARGET_S:6.2f}")


if __name__ == "__main__":
    main()
