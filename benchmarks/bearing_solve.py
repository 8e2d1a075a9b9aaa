"""Steady p-theta solve: semi-smooth Newton (oilwatch.models.bearing.film) against plain Gauss-Seidel.

Both solvers share the discretization and solve the same discrete problem on the same mesh (the
journal at its nominal equilibrium, the machine file's nominal flowrate, and a starved point at 50 % of
q_t), in one run.
Prints the median wall time of each and their ratio. Run by hand:

    OPENBLAS_NUM_THREADS=1 python benchmarks/bearing_solve.py [--mesh 100 30] [--repeats 21]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from oilwatch.models.bearing.equilibrium import static_equilibrium
from oilwatch.models.bearing.film import solve_film
from oilwatch.models.bearing.gauss_seidel import gauss_seidel_film
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S, SupplyFlow
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor


def median_seconds(repeats: int, function, *args, **kwargs) -> float:
    """Median wall time [s] of ``function(*args, **kwargs)`` over ``repeats`` calls."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function(*args, **kwargs)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh", type=int, nargs=2, default=(100, 30))
    parser.add_argument("--repeats", type=int, default=21)
    parser.add_argument("--gs-repeats", type=int, default=5)
    args = parser.parse_args()
    machine = load_machine()
    bearing = machine.bearing
    mesh = Mesh(*args.mesh)
    load, speed = float(Rotor.from_machine(machine).bearing_static_loads_n[0]), machine.nominal_speed_hz
    nominal_ml_min = machine.shared_nominal_flowrate_m3_s("benchmarks/bearing_solve.py") * ML_MIN_PER_M3_S
    print(
        f"mesh {mesh.n_circ} x {mesh.n_axial}, one thread, medians of {args.repeats} "
        f"(Newton) and {args.gs_repeats} (Gauss-Seidel) steady solves, cold start"
    )
    for q_ml_min in (nominal_ml_min, 272.0):
        supply = SupplyFlow(q_ml_min / ML_MIN_PER_M3_S)
        eq = static_equilibrium(bearing, load, speed, supply, mesh)
        ecc = tuple(eq.eccentricity_m)
        gauss_seidel_film(bearing, speed, ecc, supply, mesh=Mesh(24, 6))  # numba compile
        fast = solve_film(bearing, speed, ecc, supply, mesh=mesh)
        ref = gauss_seidel_film(bearing, speed, ecc, supply, mesh=mesh)
        state = (bearing, speed, ecc, supply)
        t_fast = median_seconds(args.repeats, solve_film, *state, mesh=mesh)
        t_warm = median_seconds(args.repeats, solve_film, *state, mesh=mesh, warm_start=eq.film)
        t_gs = median_seconds(args.gs_repeats, gauss_seidel_film, *state, mesh=mesh)
        gap = np.abs(fast.pressure_pa - ref.pressure_pa).max() / fast.pressure_pa.max()
        print(
            f"\nq = {q_ml_min} ml/min ({fast.regime}), eccentricity ratio "
            f"{eq.eccentricity_ratio:.4f}; solutions differ by {gap:.1e} of peak pressure"
        )
        print(f"  semi-smooth Newton   {t_fast * 1e3:9.1f} ms  ({fast.iterations} sparse solves)")
        print(f"  same, warm-started   {t_warm * 1e3:9.1f} ms  (as in equilibrium/coefficients)")
        print(f"  Gauss-Seidel (numba) {t_gs * 1e3:9.1f} ms  ({ref.iterations} sweeps)")
        print(f"  ratio Gauss-Seidel / Newton: {t_gs / t_fast:.1f}")


if __name__ == "__main__":
    main()
