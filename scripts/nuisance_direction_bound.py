"""Cramer-Rao bound on (q1, q2) from the estimator's own operating model (exact maps on the dimensionless
table), with the offsets, the complex unbalance and the viscosity factors unknown: the nearly unobservable
direction that estimator/nuisance_start.py is about.

    OPENBLAS_NUM_THREADS=1 python scripts/nuisance_direction_bound.py [Q1_PCT Q2_PCT]

Steady static position and 1x orbit per probe (12 numbers: static with noise variance sigma^2 / N, the
cosine and sine parts 2 sigma^2 / N), sensitivities by forward differences of the exact discrete
map (0.1 % of q, 0.1 % of each factor and of the unbalance), 1 um, 1 kHz, constant nuisances, no prior.
"""

from __future__ import annotations

import sys

import numpy as np

from models.machine import load_machine
from models.system.factory import build_system
from models.system.operating_model import build_operating_model

DT = 1e-3


def steady(model, a, g, speed_hz, unbalance=(1.0, 0.0)) -> np.ndarray:
    """(12,) static position, cosine and sine parts of the 1x orbit at the four probes [m]."""
    n = a.shape[0]
    h = np.asarray(model.output_matrix)
    static = h @ np.linalg.solve(np.eye(n) - a, g[:, 0])
    turn = np.exp(2j * np.pi * speed_hz * DT)
    orbit = complex(*unbalance) * (h @ np.linalg.solve(turn * np.eye(n) - a, g[:, 1] - 1j * g[:, 2]))
    return np.r_[static, orbit.real, -orbit.imag]


def sensitivities(model, q0: np.ndarray, speed_hz: float) -> np.ndarray:
    """(12, 10) per % of q1, q2, per unit of f1, f2, Re u, Im u, per um of the four offsets."""

    def response(q, f, u=(1.0, 0.0)):
        a, g = model.exact_map(q, f)
        return steady(model, np.asarray(a), np.asarray(g), speed_hz, u)

    base = response(q0, np.ones(2))
    columns = []
    for i in range(2):
        q = q0.copy()
        q[i] *= 1.001
        columns.append((response(q, np.ones(2)) - base) / 0.1)
    for i in range(2):
        f = np.ones(2)
        f[i] = 1.001
        columns.append((response(q0, f) - base) / 0.001)
    for i in range(2):
        u = [1.0, 0.0]
        u[i] += 0.001
        columns.append((response(q0, np.ones(2), tuple(u)) - base) / 0.001)
    columns += [np.eye(12)[i] * 1e-6 for i in range(4)]
    return np.column_stack(columns)


def bound_pct(jacobian: np.ndarray, unknown, seconds: float) -> np.ndarray:
    weights = np.sqrt(np.r_[np.ones(4), np.full(8, 0.5)])
    scaled = jacobian[:, unknown] * weights[:, None]
    fisher = scaled.T @ scaled / 1e-12 * seconds / DT
    return np.sqrt(np.diag(np.linalg.inv(fisher)))[:2]


def main() -> None:
    point = tuple(float(v) for v in sys.argv[1:3]) if len(sys.argv) >= 3 else (100.0, 100.0)
    machine = load_machine()
    model = build_operating_model(build_system(machine, reduced=True), machine, DT)
    model.set_operating_point(machine.nominal_speed_hz, machine.nominal_oil_temperature_c, None)
    q0 = np.array(point) / 100.0 * machine.lubrication.nominal_flowrate_m3_s
    jacobian = sensitivities(model, q0, machine.nominal_speed_hz)
    groups = {
        "offsets + unbalance": [0, 1, 4, 5, 6, 7, 8, 9],
        "viscosity factors": [0, 1, 2, 3],
        "offsets + viscosity": [0, 1, 2, 3, 6, 7, 8, 9],
        "offsets + unbalance + viscosity": list(range(10)),
    }
    print(f"| {point[0]:g}/{point[1]:g} % unknown | 10 s | 60 s |\n|---|---|---|")
    for name, unknown in groups.items():
        ten, sixty = bound_pct(jacobian, unknown, 10.0), bound_pct(jacobian, unknown, 60.0)
        print(f"| {name} | {ten[0]:.2f} / {ten[1]:.2f} | {sixty[0]:.2f} / {sixty[1]:.2f} |")


if __name__ == "__main__":
    main()
