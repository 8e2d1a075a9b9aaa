"""How far the estimator's operating model is from the exact maps along the robustness ramps, and the bias
that error gives an estimator of constant parameters along the nearly unobservable direction.

    OPENBLAS_NUM_THREADS=1 python scripts/nuisance_model_error_bias.py [--re-centre-scale 1]

The operating model (``models/system/operating_model.py``) is the exact map at its correction's centre plus
first-order terms in (q, speed, ln mu) between re-centrings. Along each ramp at the true flowrates and
factors 1 the centre moves as the model's thresholds say (``Recentring``, times ``--re-centre-scale``),
and at every 0.1 s the steady static position and 1x orbit of the model's map (``discrete_map``) are
compared with those of the exact map (``OperatingMaps.discrete_map``, which the plant of these cases
shares). The error e(t) (12 numbers) gives the least-squares bias of the constant parameters
(``oilwatch.models.system.identifiability``: ``(sum J^T W J)^-1 sum J^T W e``), with the offsets, unbalance
and factors unknown and with the factors known.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import build_system
from oilwatch.models.system.identifiability import (
    OperatingSegment,
    map_response,
    map_sensitivity,
    parameter_columns,
)
from oilwatch.models.system.operating_model import Recentring, build_operating_model

DT = 1e-3
WEIGHTS = np.r_[np.ones(4), np.full(8, 0.5)]


def ramp(machine, kind: str, t: float, duration: float) -> tuple[float, float]:
    s = t / duration
    speed = 72.0 + 6.0 * s if kind == "speed ramp" else machine.nominal_speed_hz
    rise = 10.0 * s if kind == "temperature ramp" else 0.0
    return speed, machine.nominal_oil_temperature_c + rise


def model_response(model, q, speed, temperature, centre: dict) -> np.ndarray:
    """(12,) the operating model's steady response at the point, its centre (``centre["point"]``) moved
    as its thresholds say."""
    model.set_operating_point(speed, temperature)
    _, viscosity = model.operating_point
    point = np.array([q[0], q[1], speed, math.log(viscosity), math.log(viscosity)])
    r = model.recentring
    scales = np.r_[np.full(2, r.flowrate_fraction * model.nominal_flowrate_m3_s), r.speed_fraction * 75.0]
    last = centre.get("point")
    if (
        last is None
        or max(
            np.max(np.abs(point[:3] - last[:3]) / scales),
            np.max(np.abs(point[3:] - last[3:])) / r.log_viscosity,
        )
        > 1.0
    ):
        model.place_centre(point)
        centre["point"] = point
    a, g = model.discrete_map(q, (1.0, 1.0))
    n = a.shape[0]
    h = np.asarray(model.output_matrix)
    static = h @ np.linalg.solve(np.eye(n) - a, g[:, 0])
    turn = np.exp(2j * np.pi * speed * DT)
    orbit = h @ np.linalg.solve(turn * np.eye(n) - a, g[:, 1] - 1j * g[:, 2])
    return np.r_[static, orbit.real, -orbit.imag]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--re-centre-scale", type=float, default=1.0, help="thresholds times this")
    parser.add_argument("--duration-s", type=float, default=60.0)
    args = parser.parse_args()
    machine = load_machine()
    k = args.re_centre_scale
    base = Recentring()
    recentring = dataclasses.replace(
        base,
        speed_fraction=base.speed_fraction * k,
        log_viscosity=base.log_viscosity * k,
        flowrate_fraction=base.flowrate_fraction * k,
    )
    model = build_operating_model(build_system(machine, reduced=True), machine, DT, recentring=recentring)
    maps, h = model.maps, np.asarray(model.output_matrix)
    nominal = machine.lubrication.nominal_flowrate_m3_s
    header = (
        "| point | trajectory | rms model error [nm] | bias, all unknown [% q] | bias, factors known [% q] |"
    )
    print(header)
    print("|---|---|---|---|---|")
    for point in ((100.0, 100.0), (80.0, 90.0)):
        q = np.array(point) / 100.0 * nominal
        for kind in ("constant", "temperature ramp", "speed ramp"):
            model.reset_operating_state()
            centre: dict = {}
            fisher, score, errors = np.zeros((10, 10)), np.zeros(10), []
            for t in np.arange(0.05, args.duration_s, 0.1):
                speed, temperature = ramp(machine, kind, t, args.duration_s)
                model.set_operating_point(speed, temperature)
                segment = OperatingSegment(speed, model.operating_point[1], 0.1)
                exact = map_response(maps, h, DT, q, segment, (1.0, 1.0), 1.0)
                error = model_response(model, q, speed, temperature, centre) - exact
                jac = map_sensitivity(maps, h, DT, q, segment)
                fisher += (jac.T * WEIGHTS) @ jac
                score += (jac.T * WEIGHTS) @ error
                errors.append(error)
            rms = 1e9 * math.sqrt(np.mean(np.square(errors)))
            cells = []
            for groups in (("offsets", "unbalance", "viscosity"), ("offsets", "unbalance")):
                c = parameter_columns(groups)
                bias = np.linalg.solve(fisher[np.ix_(c, c)], score[c])[:2]
                cells.append(f"{100 * bias[0]:+.2f} / {100 * bias[1]:+.2f}")
            row = f"| {point[0]:g}/{point[1]:g} % | {kind} | {rms:.2f} | {cells[0]} | {cells[1]} |"
            print(row, flush=True)


if __name__ == "__main__":
    main()
