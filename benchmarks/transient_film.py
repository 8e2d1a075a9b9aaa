"""Transient film step (both bearings) against the steady solve, on one mesh, in one run.

The journals follow a 3 um circular whirl at the machine's nominal speed (64 steps per revolution) about
the equilibrium at its nominal flowrate; after a warm-up (one revolution unless ``--warmup-steps``) the
wall time of each step of both bearings is recorded (warm: partitions, LU preconditioners and numba
caches in place), for the default stepper (projected multigrid on meshes above 1000 volumes, projected
SOR sweeps below; the active set as the fallback; the mid-plane symmetric half unless ``--whole``) at
the film tolerances given (default: the studies' 1e-11 residual and 1e-10 mass balance; the plant's are
1e-8 and 1e-7), and for the active set alone. Beside them the warm-started steady solve (``solve_film``
from the neighbouring solution, whole film) at the same positions. Prints wall-time medians, their
ratios, the process CPU time (what one core spends, less inflated than the wall time on a shared
machine), the cycles or sweeps per step, the residual they reached and the largest mass-balance error
of a step. Run by hand:

    OPENBLAS_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/transient_film.py [--mesh 240 72]
        [--revolutions 2] [--warmup-steps 64] [--residual-tolerance 1e-11] [--mass-tolerance 1e-10]
        [--whole]
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time

import numpy as np

from oilwatch.models.bearing.equilibrium import static_equilibrium
from oilwatch.models.bearing.film import solve_film
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.supply import SupplyFlow
from oilwatch.models.bearing.transient import (
    SWEEP_MASS_TOLERANCE,
    SWEEP_RESIDUAL_TOLERANCE,
    TransientFilm,
    mass_balance_error,
)
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh", type=int, nargs=2, default=(240, 72))
    parser.add_argument("--revolutions", type=int, default=2, help="measured revolutions (64 steps each)")
    parser.add_argument("--warmup-steps", type=int, default=64, help="steps before the measurement (64)")
    parser.add_argument("--residual-tolerance", type=float, default=SWEEP_RESIDUAL_TOLERANCE)
    parser.add_argument("--mass-tolerance", type=float, default=SWEEP_MASS_TOLERANCE)
    parser.add_argument(
        "--whole", action="store_true", help="solve the whole film, not the mid-plane symmetric half"
    )
    args = parser.parse_args()
    machine = load_machine(None)
    mesh = Mesh(*args.mesh)
    q = machine.shared_nominal_flowrate_m3_s("benchmarks/transient_film.py")
    speed = machine.nominal_speed_hz
    supply = SupplyFlow(q)
    load = float(Rotor.from_machine(machine).bearing_static_loads_n[0])
    eq = static_equilibrium(machine.bearing, load, speed, supply, mesh)
    options = {
        "residual_tolerance": args.residual_tolerance,
        "mass_tolerance": args.mass_tolerance,
        "symmetric": False if args.whole else None,
    }
    steppers = {
        "default": [TransientFilm(machine.bearing, speed, mesh, **options) for _ in range(2)],
        "active set only": [
            TransientFilm(machine.bearing, speed, mesh, solver="active-set", **options) for _ in range(2)
        ],
    }
    states = {
        name: [f.from_steady(eq.film, eq.eccentricity_m) for f in films] for name, films in steppers.items()
    }
    times = {name: [] for name in steppers}
    cpu = {name: [] for name in steppers}
    balance = dict.fromkeys(steppers, 0.0)
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
            before = states[name]
            states[name] = [f.step(s, e, q, dt) for f, s in zip(films, before, strict=True)]
            if k > warmup:
                times[name].append(time.perf_counter() - start)
                cpu[name].append(time.process_time() - start_cpu)
                balance[name] = max(
                    balance[name],
                    *(
                        abs(mass_balance_error(f, a, b))
                        for f, a, b in zip(films, before, states[name], strict=True)
                    ),
                )
        start, start_cpu = time.perf_counter(), time.process_time()
        previous = solve_film(machine.bearing, speed, tuple(e), supply, mesh=mesh, warm_start=previous)
        if k > warmup:
            steady.append(time.perf_counter() - start)
            steady_cpu.append(time.process_time() - start_cpu)
            sweeps.extend(s.sweeps for s in states["default"])
            residuals.extend(s.sweep_residual for s in states["default"])
    s_med = statistics.median(steady)
    films = steppers["default"]
    print(
        f"mesh {mesh.n_circ} x {mesh.n_axial} ({films[0].grid.n_nodes} volumes solved, "
        f"{'mid-plane half' if films[0].symmetric else 'whole film'}), solver {films[0].solver}, "
        f"tolerances {args.residual_tolerance:.0e} / {args.mass_tolerance:.0e}, {len(steady)} steps, "
        f"load {os.getloadavg()[0]:.1f}"
    )
    for name, values in times.items():
        med = statistics.median(values)
        print(
            f"transient step, both bearings, {name}: median {med * 1e3:.2f} ms ({med / s_med:.2f} x steady), "
            f"process CPU time median {statistics.median(cpu[name]) * 1e3:.2f} ms; "
            f"largest mass-balance error {balance[name]:.1e} of the supply"
        )
    print(
        f"steady solve, one bearing (warm-started): median {s_med * 1e3:.2f} ms, "
        f"process CPU time median {statistics.median(steady_cpu) * 1e3:.2f} ms"
    )
    print(
        f"sweeps (multigrid: cycles) per bearing-step: median {statistics.median(sweeps):.0f}, "
        f"max {max(sweeps)} "
        f"(limit {films[0].sweep_limit}); residual reached: median {statistics.median(residuals):.1e} "
        f"of U c L / 2 (tolerance {films[0].residual_tolerance:.0e}); active set finished "
        f"{sum(f.fallbacks for f in films)} of {2 * n_steps} bearing-steps"
    )
    direct = steppers["active set only"][0]
    print(f"LU factorizations per bearing-step (active set only): {direct.factorizations / n_steps:.2f}")
    worst = max(
        np.abs(a.force_n - b.force_n).max()
        for a, b in zip(states["default"], states["active set only"], strict=True)
    )
    print(f"largest force difference of the two steppers at the end: {worst:.2e} N (load {load:.0f} N)")


if __name__ == "__main__":
    main()
