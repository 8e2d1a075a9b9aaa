"""CPU time of the high-fidelity plant's 1 ms samples (the rotor on two transient films), warm.

The plant of ``film_model = "transient-film"``
(:class:`oilwatch.models.system.nonlinear_plant.TransientFilmPlant`: 3 implicit substeps per sample, the
plant's film tolerances) on its 60 x 16 mesh, both supplies falling from the nominal flowrate to 75 % (a
sigmoid centred at 50 ms, 10 ms wide). After the set-up and 20 warm-up samples, the process CPU time of each
of ``--samples`` samples; prints its median and mean and the last true journal position (the same on any code
that leaves the iterates unchanged). A short piece of the 20 s high-fidelity run. Run by hand:

    OPENBLAS_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/transient_plant_sample.py [--samples 100]
"""

from __future__ import annotations

import argparse
import statistics
import time

from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.machine import load_machine
from oilwatch.models.system.fault import SigmoidFlowrate
from oilwatch.models.system.nonlinear_plant import TRANSIENT_PLANT_MESH, TransientFilmPlant


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=100, help="measured 1 ms samples (100)")
    args = parser.parse_args()
    machine = load_machine(None)
    q = machine.shared_nominal_flowrate_m3_s("benchmarks/transient_plant_sample.py")
    schedules = tuple(SigmoidFlowrate(q, 0.75 * q, 0.05, 0.01) for _ in range(2))
    start = time.process_time()
    plant = TransientFilmPlant(machine, Mesh(*TRANSIENT_PLANT_MESH), 1e-3, schedules, 1e-6, seed=3)
    for _ in range(20):
        plant.step()
    setup = time.process_time() - start
    cpu = []
    for _ in range(args.samples):
        start = time.process_time()
        sample = plant.step()
        cpu.append(time.process_time() - start)
    print(
        f"set-up and 20 warm-up samples: {setup:.1f} s CPU; per 1 ms sample ({args.samples}): median "
        f"{statistics.median(cpu) * 1e3:.2f} ms CPU, mean {statistics.mean(cpu) * 1e3:.2f} ms; "
        f"last true position (x1, y1) {sample.true_position_m[0]:.6e}, {sample.true_position_m[1]:.6e} m"
    )


if __name__ == "__main__":
    main()
