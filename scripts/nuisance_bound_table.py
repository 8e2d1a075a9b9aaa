"""Print the README's table of the Cramer-Rao bound on (q1, q2) with the machine's nuisances unknown.

Full rotor-bearing model of the machine file, 1 kHz, sigma 1 um; records of 10, 60 and 600 s at (100, 100) %
and (80, 90) % of nominal; without a baseline and with a baseline (60 s at nominal flowrates, known), the
latter also with the probe offsets drifted by 3 um (std) since the baseline. The viscosity sensitivity
re-solves the film at mu (1 +- 1 %) (two solves per flowrate, about 4 s each).

Usage: ``OPENBLAS_NUM_THREADS=1 python scripts/nuisance_bound_table.py [--machine FILE] [--noise-um 1]``
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import build_system
from oilwatch.models.system.nuisance_bound import nuisance_bound, viscosity_derivative

RECORDS_S = (10, 60, 600)
POINTS = ((100.0, 100.0), (80.0, 90.0))
ROWS = (
    ("all known", ()),
    ("unbalance (complex)", ("unbalance",)),
    ("probe offsets", ("offsets",)),
    ("offsets + unbalance", ("offsets", "unbalance")),
    ("viscosity factors", ("viscosity",)),
    ("offsets + unbalance + viscosity", ("offsets", "unbalance", "viscosity")),
)
BASELINE_S = 60
DRIFT_UM = 3.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--machine", default=None, help="machine file (default: the bundled turbine)")
    parser.add_argument("--noise-um", type=float, default=1.0, help="probe noise std [um]")
    args = parser.parse_args()
    machine = load_machine(args.machine)
    system = build_system(machine, reduced=False)
    nominal = machine.lubrication.nominal_flowrate_m3_s
    cache: dict[tuple[int, float], object] = {}
    synchronous = system.synchronous_tables is not None

    def derivatives(flows):
        out = []
        for b, q in enumerate(flows):
            key = (b, round(float(q) * 6e7, 6))
            if key not in cache:
                cache[key] = viscosity_derivative(system.tables[b], float(q), synchronous=synchronous)
            out.append(cache[key])
        return out

    sigma = args.noise_um * 1e-6
    dt = 1e-3
    header = ["point", "unknown"] + [f"{r} s" for r in RECORDS_S]
    header += [f"{r} s, baseline" for r in RECORDS_S] + [
        f"{r} s, baseline, drift {DRIFT_UM:g} um" for r in RECORDS_S
    ]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for point in POINTS:
        q = np.array(point) / 100.0 * nominal
        for label, groups in ROWS:
            cells = []
            for baseline, drift in ((False, None), (True, None), (True, {"offset": DRIFT_UM})):
                for seconds in RECORDS_S:
                    bound = nuisance_bound(
                        system,
                        q,
                        sigma,
                        round(seconds / dt),
                        groups,
                        dt_s=dt,
                        viscosity_derivatives=derivatives,
                        baseline_flowrates_m3_s=(nominal, nominal) if baseline else None,
                        baseline_samples=round(BASELINE_S / dt),
                        drift_std=drift,
                    )
                    cells.append(f"{bound.std_pct[0]:.3f}/{bound.std_pct[1]:.3f}")
            print(f"| {point[0]:g}/{point[1]:g} % | {label} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
