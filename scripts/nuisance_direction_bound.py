"""Cramer-Rao bound on (q1, q2) from the estimator's own operating model (exact maps on the dimensionless
table), at constant conditions and along the robustness report's ramps, with the offsets, the complex
unbalance and the viscosity factors unknown: the nearly unobservable direction that
estimator/nuisance_start.py is about.

    OPENBLAS_NUM_THREADS=1 python scripts/nuisance_direction_bound.py [--duration-s 60]

Per truth point (100/100, 80/90 %) and trajectory (constant; oil temperature +10 degC over the record; speed
72 -> 78 Hz), the bound with each set of nuisances unknown, without and with a commissioning baseline (a
record as long as the run at 100/100 % and the trajectory's start conditions, flowrates known), 1 um, 1 kHz,
constant nuisances (``oilwatch.models.system.trajectory_bound.trajectory_information``, 12 quasi-steady
segments); and the posterior bound at the end of the record with the parameters random-walking as the
robustness run's estimator models them (``tracking_bound_pct``: EKFConfig's flowrate process noise, factor and
unbalance walks, the machine file's offset walk; priors: a quarter of nominal, 0.1, 2, the probes' 25 um).
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from oilwatch.estimator.ekf_config import (
    UNBALANCE_RANDOM_WALK_SQRT_S,
    VISCOSITY_FACTOR_RANDOM_WALK_SQRT_S,
    EKFConfig,
)
from oilwatch.models.machine import load_machine
from oilwatch.models.probes import read_probes
from oilwatch.models.system.factory import build_system
from oilwatch.models.system.operating_model import build_operating_model
from oilwatch.models.system.trajectory_bound import (
    OperatingSegment,
    nuisance_prior,
    tracking_bound_pct,
    trajectory_bound_pct,
    trajectory_information,
)

DT = 1e-3
SEGMENTS = 12
GROUPS = {
    "offsets + unbalance": ("offsets", "unbalance"),
    "viscosity factors": ("viscosity",),
    "offsets + unbalance + viscosity": ("offsets", "unbalance", "viscosity"),
}


def trajectory(machine, kind: str, duration_s: float, count: int) -> list[OperatingSegment]:
    """``count`` segments of a constant record, the +10 degC oil ramp or the 72 -> 78 Hz speed ramp."""
    t0 = machine.nominal_oil_temperature_c
    out = []
    for i in range(count):
        s = (i + 0.5) / count if count > 1 else 0.0
        speed = 72.0 + 6.0 * s if kind == "speed ramp" else machine.nominal_speed_hz
        temperature = t0 + 10.0 * s if kind == "temperature ramp" else t0
        out.append(
            OperatingSegment(speed, machine.oil.dynamic_viscosity_pa_s(temperature), duration_s / count)
        )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration-s", type=float, default=60.0, help="record length [s]")
    args = parser.parse_args()
    machine = load_machine()
    model = build_operating_model(build_system(machine, reduced=True), machine, DT)
    maps, h = model.maps, np.asarray(model.output_matrix)
    nominal = machine.lubrication.nominal_flowrate_m3_s
    config, probes = EKFConfig(), read_probes(machine)
    walks = np.r_[
        np.full(2, config.flowrate_process_std_m3_s / np.sqrt(DT)),
        np.full(2, VISCOSITY_FACTOR_RANDOM_WALK_SQRT_S),
        np.full(2, UNBALANCE_RANDOM_WALK_SQRT_S),
        np.full(4, probes.offset_random_walk_m_sqrt_s * 1e6),
    ]
    priors = np.r_[
        np.full(2, 0.25 * nominal), 0.1, 0.1, 2.0, 2.0, np.full(4, probes.offset_prior_std_m * 1e6)
    ]
    d = args.duration_s
    print(f"| point | trajectory | unknown | {d:g} s | {d:g} s, baseline | filter's walks, end of {d:g} s |")
    print("|---|---|---|---|---|---|")
    for point in ((100.0, 100.0), (80.0, 90.0)):
        q = np.array(point) / 100.0 * nominal
        for kind in ("constant", "temperature ramp", "speed ramp"):
            segments = trajectory(machine, kind, args.duration_s, SEGMENTS)
            info = trajectory_information(maps, h, DT, q, segments, 1e-6)
            rates = [
                (trajectory_information(maps, h, DT, q, [s], 1e-6) / s.duration_s, s.duration_s)
                for s in segments
            ]
            scale = np.r_[1.0 / q, np.ones(8)]  # the flowrates as fractions of the truth
            start = trajectory(machine, kind, args.duration_s, 1)[0]
            if kind == "speed ramp":
                start = OperatingSegment(72.0, start.oil_viscosity_pa_s, args.duration_s)
            baseline = trajectory_information(maps, h, DT, np.full(2, nominal), [start], 1e-6)
            for name, groups in GROUPS.items():
                alone = trajectory_bound_pct(info, groups)
                primed = trajectory_bound_pct(info, groups, nuisance_prior(baseline, groups))
                walking = tracking_bound_pct(rates, groups, priors * scale, walks * scale)
                print(
                    f"| {point[0]:g}/{point[1]:g} % | {kind} | {name} | {alone[0]:.2f} / {alone[1]:.2f} "
                    f"| {primed[0]:.3f} / {primed[1]:.3f} | {walking[0]:.2f} / {walking[1]:.2f} |"
                )


if __name__ == "__main__":
    main()
