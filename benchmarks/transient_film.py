"""Transient film step (both bearings) against the steady solve, on one mesh, in one run.

The journals follow a 3 um circular whirl at the machine's nominal speed (64 steps per revolution) about
the equilibrium at its nominal flowrate; after one warm-up revolution the wall time of each step of
both bearings is recorded (warm: partitions, LU preconditioners and numba caches in place). Beside
it the warm-started steady solve (``solve_film`` from the neighbouring solution) at the same
positions. Prints medians and their ratio. Run by hand:

    OPENBLAS_NUM_THREADS=1 python benchmarks/transient_film.py [--mesh 240 72] [--revolutions 2]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

from models.bearing.equilibrium import static_equilibrium
from models.bearing.film import solve_film
from models.bearing.grid import Mesh
from models.bearing.supply import SupplyFlow
from models.bearing.transient import TransientFilm
from models.machine import load_machine
from models.rotor.assembly import Rotor


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh", type=int, nargs=2, default=(240, 72))
    parser.add_argument("--revolutions", type=int, default=2)
    args = parser.parse_args()
    machine = load_machine(None)
    mesh = Mesh(*args.mesh)
    q = machine.lubrication.nominal_flowrate_m3_s
    speed = machine.nominal_speed_hz
    supply = SupplyFlow(q)
    load = float(Rotor.from_machine(machine).bearing_static_loads_n[0])
    eq = static_equilibrium(machine.bearing, load, speed, supply, mesh)
    films = [TransientFilm(machine.bearing, speed, mesh) for _ in range(2)]
    states = [f.from_steady(eq.film, eq.eccentricity_m) for f in films]
    omega = 2.0 * math.pi * speed
    dt = 1.0 / speed / 64
    transient, steady = [], []
    previous = eq.film
    for k in range(1, 64 * (1 + args.revolutions) + 1):
        e = eq.eccentricity_m + 3e-6 * np.array([math.cos(omega * k * dt) - 1.0, math.sin(omega * k * dt)])
        start = time.perf_counter()
        states = [f.step(s, e, q, dt) for f, s in zip(films, states, strict=True)]
        elapsed = time.perf_counter() - start
        start = time.perf_counter()
        previous = solve_film(machine.bearing, speed, tuple(e), supply, mesh=mesh, warm_start=previous)
        elapsed_steady = time.perf_counter() - start
        if k > 64:
            transient.append(elapsed)
            steady.append(elapsed_steady)
    t_med = statistics.median(transient)
    s_med = statistics.median(steady)
    print(f"mesh {mesh.n_circ} x {mesh.n_axial} ({films[0].grid.n_nodes} volumes), {len(transient)} steps")
    print(f"transient step, both bearings: median {t_med * 1e3:.2f} ms")
    print(f"steady solve, one bearing (warm-started): median {s_med * 1e3:.2f} ms")
    print(f"ratio transient (2 bearings) / steady (1 bearing): {t_med / s_med:.2f}")
    print(
        f"LU factorizations per bearing-step: {films[0].factorizations / (64 * (1 + args.revolutions)):.2f}"
    )


if __name__ == "__main__":
    main()
