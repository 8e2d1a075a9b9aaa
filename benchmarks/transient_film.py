"""Transient film step (both bearings) against the steady solve, on one mesh, in one run.

The journals follow a 3 um circular whirl at the machine's nominal speed (64 steps per revolution) about
the equilibrium at its nominal flowrate; after a warm-up (one revolution unless ``--warmup-steps``) the
wall time of each step of both bearings is recorded (warm: partitions, LU preconditioners and numba
caches in place), for the default stepper (projected SOR sweeps, active set as fallback or finisher)
and for the active set alone. Beside them the warm-started steady solve (``solve_film`` from the
neighbouring solution) at the same positions. Prints wall-time medians, their ratios, the process CPU
time (what one core spends, less inflated than the wall time on a shared machine), the sweeps per step
and the residual they reached. Run by hand:

    OPENBLAS_NUM_THREADS=1 python benchmarks/transient_film.py [--mesh 240 72] [--revolutions 2]
        [--warmup-steps 64]
"""

from __future__ import annotations

import argparse
import math
import os
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
    parser.add_argument("--revolutions", type=int, default=2, help="measured revolutions (64 steps each)")
    parser.add_argument("--warmup-steps", type=int, default=64, help="steps before the measurement (64)")
    args = parser.parse_args()
    machine = load_machine(None)
    mesh = Mesh(*args.mesh)
    q = machine.lubrication.nominal_flowrate_m3_s
    speed = machine.nominal_speed_hz
    supply = SupplyFlow(q)
    load = float(Rotor.from_machine(machine).bearing_static_loads_n[0])
    eq = static_equilibrium(machine.bearing, load, speed, supply, mesh)
    steppers = {
        "default (sweeps)": [TransientFilm(machine.bearing, speed, mesh) for _ in range(2)],
        "active set only": [TransientFilm(machine.bearing, speed, mesh, sweep_limit=0) for _ in range(2)],
    }
    states = {
        name: [f.from_steady(eq.film, eq.eccentricity_m) for f in films] for name, films in steppers.items()
    }
    times = {name: [] for name in steppers}
    cpu = {name: [] for name in steppers}
    sweeps, residuals, steady, steady_cpu = [], [], [], []
    omega = 2.0 * math.pi * speed
    dt = 1.0 / speed / 64
    previous = eq.film
    warmup = args.warmup_steps
    n_steps = warmup + 64 * args.revolutions
    for k in range(1, n_steps + 1):
        e = eq.eccentricity_m + 3e-6 * np.array([math.cos(omega * k * dt) - 1.0, math.sin(omega * k * dt)])
        for name, films in steppers.items():
            start, start_cpu = time.perf_counter(), time.process_time()
            states[name] = [f.step(s, e, q, dt) for f, s in zip(films, states[name], strict=True)]
            if k > warmup:
                times[name].append(time.perf_counter() - start)
                cpu[name].append(time.process_time() - start_cpu)
        start, start_cpu = time.perf_counter(), time.process_time()
        previous = solve_film(machine.bearing, speed, tuple(e), supply, mesh=mesh, warm_start=previous)
        if k > warmup:
            steady.append(time.perf_counter() - start)
            steady_cpu.append(time.process_time() - start_cpu)
            sweeps.extend(s.sweeps for s in states["default (sweeps)"])
            residuals.extend(s.sweep_residual for s in states["default (sweeps)"])
    s_med = statistics.median(steady)
    films = steppers["default (sweeps)"]
    print(
        f"mesh {mesh.n_circ} x {mesh.n_axial} ({films[0].grid.n_nodes} volumes), {len(steady)} steps, "
        f"load {os.getloadavg()[0]:.1f}"
    )
    for name, values in times.items():
        med = statistics.median(values)
        print(
            f"transient step, both bearings, {name}: median {med * 1e3:.2f} ms ({med / s_med:.2f} x steady), "
            f"process CPU time median {statistics.median(cpu[name]) * 1e3:.2f} ms"
        )
    print(
        f"steady solve, one bearing (warm-started): median {s_med * 1e3:.2f} ms, "
        f"process CPU time median {statistics.median(steady_cpu) * 1e3:.2f} ms"
    )
    print(
        f"sweeps per bearing-step: median {statistics.median(sweeps):.0f}, max {max(sweeps)} "
        f"(limit {films[0].sweep_limit}); residual reached: median {statistics.median(residuals):.1e} "
        f"of U c L / 2 (tolerance {films[0].residual_tolerance:.0e}); active set finished "
        f"{sum(f.fallbacks for f in films)} of {2 * n_steps} bearing-steps"
    )
    direct = steppers["active set only"][0]
    print(f"LU factorizations per bearing-step (active set only): {direct.factorizations / n_steps:.2f}")
    worst = max(
        np.abs(a.force_n - b.force_n).max()
        for a, b in zip(states["default (sweeps)"], states["active set only"], strict=True)
    )
    print(f"largest force difference of the two steppers at the end: {worst:.2e} N (load {load:.0f} N)")


if __name__ == "__main__":
    main()
