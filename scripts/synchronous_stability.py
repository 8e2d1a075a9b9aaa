"""Why the synchronous coefficients set only the 1x load: the free modes of each constant-coefficient model.

At the nominal speed and flowrates from 50 % to 125 % of nominal, the largest real part of the state
matrix's eigenvalues (and that mode's frequency) of the rotor on constant quasi-static coefficients and on
constant synchronous K(Omega), C(Omega); then the exact roots of the rotor on the linearized transient films
(impedance Z(s), oilwatch.models.system.frequency_stability.film_roots) at 100 % and 75 %, the reference.

    OPENBLAS_NUM_THREADS=1 python scripts/synchronous_stability.py [--mesh 60x16]
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from oilwatch.models.bearing.coefficient_kinds import QUASI_STATIC
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.factory import build_system, flowrate_table_path
from oilwatch.models.system.frequency_stability import film_impedances, film_roots, least_stable

FRACTIONS = (0.5, 0.75, 0.8, 0.95, 1.0, 1.25)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh", default="60x16", help="film mesh of the exact roots (N_CIRCxN_AXIAL)")
    args = parser.parse_args()
    machine = load_machine()
    speed = machine.nominal_speed_hz
    nominal = machine.lubrication.nominal_flowrate_m3_s
    models = {
        "quasi-static": build_system(machine, reduced=False, coefficients=QUASI_STATIC),
        "synchronous (constant)": build_system(
            machine, reduced=False, table_path=flowrate_table_path(machine, speed, "synchronous")
        ),
    }
    print(f"{speed:g} Hz: largest Re(eigenvalue) [1/s] at its frequency [Hz], per flowrate [% of nominal]")
    for name, system in models.items():
        low, high = system.flowrate_bounds_m3_s
        cells = []
        for fraction in FRACTIONS:
            q = float(np.clip(fraction * nominal, low, high))
            eigenvalues = np.linalg.eigvals(system.state_space((q, q))[0])
            top = eigenvalues[np.argmax(eigenvalues.real)]
            cells.append(f"{100 * fraction:g} %: {top.real:+.2f} at {abs(top.imag) / (2 * np.pi):.1f}")
        print(f"  {name:24s}" + "; ".join(cells))
    n_circ, n_axial = (int(v) for v in args.mesh.split("x"))
    rotor = Rotor.from_machine(machine)
    print(f"exact roots on the linearized transient films ({args.mesh}): least log decrement, frequency")
    for fraction in (1.0, 0.75):
        impedances, quasi = film_impedances(machine, rotor, speed, fraction * nominal, Mesh(n_circ, n_axial))
        mode = least_stable(film_roots(rotor, speed, impedances, quasi))
        print(f"  {100 * fraction:g} %: {mode.log_decrement:.3f} at {mode.frequency_hz:.1f} Hz")


if __name__ == "__main__":
    main()
