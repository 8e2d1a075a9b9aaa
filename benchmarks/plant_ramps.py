"""Real-time factor of the plant model under speed and oil-temperature ramps (issue 13), in process.

Three runs of ``oilwatch.models.system.plant.RotorBearingPlant.step`` at 1 ms, nominal flowrates, each
repeated:

- ``flowrate table, constant``: the classic plant on the 75 Hz flowrate table (the baseline);
- ``dimensionless table, constant``: the plant on the dimensionless table at the nominal operating point;
- ``dimensionless table, ramps``: speed 72 -> 78 Hz over 10 s and oil temperature +10 degC over 60 s
  (the issue's ramps: every step changes the operating point, so the integrator takes its sub-step path).

Prints the median wall time per step, the real-time factor and the ratio to the baseline.

Usage: ``OPENBLAS_NUM_THREADS=1 python benchmarks/plant_ramps.py [--duration-s 5] [--repeats 3]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.operating_point import operating_system
from oilwatch.models.system.plant import RotorBearingPlant

Q = load_machine().shared_nominal_flowrate_m3_s(
    "benchmarks/plant_ramps.py"
)  # the machine file's nominal supply flowrate


def run(kind: str, steps: int) -> float:
    machine = load_machine()
    t0 = machine.nominal_oil_temperature_c
    if kind == "flowrate table, constant":
        plant = RotorBearingPlant(
            load_system(reduced=False), 1e-3, None, 1e-6, 1, initial_flowrates_m3_s=(Q, Q)
        )
    else:
        system = operating_system(machine, 72.0 if "ramps" in kind else 75.0, machine.bearing.viscosity_pa_s)
        plant = RotorBearingPlant(
            system, 1e-3, None, 1e-6, 1, initial_flowrates_m3_s=(Q, Q), oil=machine.oil, oil_temperature_c=t0
        )
    started = time.perf_counter()
    for k in range(1, steps + 1):
        if "ramps" in kind:
            t = k * 1e-3
            plant.step((Q, Q), speed_hz=72.0 + 0.6 * min(t, 10.0), oil_temperature_c=t0 + 10.0 * t / 60.0)
        else:
            plant.step((Q, Q))
    return (time.perf_counter() - started) / steps


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--duration-s", type=float, default=5.0)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    steps = round(args.duration_s / 1e-3)
    kinds = ("flowrate table, constant", "dimensionless table, constant", "dimensionless table, ramps")
    medians = {k: statistics.median(run(k, steps) for _ in range(args.repeats)) for k in kinds}
    base = medians[kinds[0]]
    print(f"{steps} steps of 1 ms, median of {args.repeats}")
    for kind, wall in medians.items():
        print(
            f"{kind:32s} {wall * 1e6:8.1f} us/step  real-time factor {1e-3 / wall:7.1f}  x{wall / base:5.2f}"
        )


if __name__ == "__main__":
    main()
