"""The ramp identification of ``scripts/ramp_identification.py`` in process, with the viscosity-factor states.

The plant (``RotorBearingPlant`` on the dimensionless table, full-order Newmark model) follows the issue's
ramps (72 -> 78 Hz over 10 s, +10 degC over 60 s) at constant flowrates, with a film ``viscosity_factor``
(the film's viscosity over the oil law's); the estimator (``OperatingAugmentedModel``) is fed the same
measured speed and oil temperature, with the viscosity factors known (prior std 0) or estimated.

    nice -n 10 python scripts/ramp_identification_in_process.py [--q-pct 100 100] [--duration-s 20]
        [--viscosity-prior-std 0.05] [--plant-viscosity-factor 0.9]

Prints the mean relative error and std over the last 5 s, the alarm samples after 2 s, the final viscosity
factors and the number of re-centrings.
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.operating_model import build_operating_model
from oilwatch.models.system.operating_point import operating_system
from oilwatch.models.system.plant import RotorBearingPlant
from oilwatch.models.system.profiles import OperatingProfile


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--q-pct", type=float, nargs=2, default=(100.0, 100.0))
    parser.add_argument("--duration-s", type=float, default=20.0)
    parser.add_argument("--viscosity-prior-std", type=float, default=0.0)
    parser.add_argument("--plant-viscosity-factor", type=float, default=1.0)
    args = parser.parse_args()
    machine = load_machine()
    t0 = machine.nominal_oil_temperature_c
    speed = OperatingProfile("ramp", 72.0, 78.0, 0.0, 10.0)
    temperature = OperatingProfile("ramp", t0, t0 + 10.0, 0.0, 60.0)
    q = np.array(args.q_pct) / 100.0 * machine.lubrication.nominal_flowrate_m3_s
    system = operating_system(machine, speed(0.0), machine.oil.dynamic_viscosity_pa_s(temperature(0.0)))
    plant = RotorBearingPlant(
        system, 1e-3, None, 1e-6, 3, initial_flowrates_m3_s=tuple(q), oil=machine.oil,
        oil_temperature_c=temperature(0.0), viscosity_factor=args.plant_viscosity_factor,
    )  # fmt: skip
    model = build_operating_model(load_system(reduced=True), machine)
    config = EKFConfig.recommended(
        first_sample_time_s=1e-3, viscosity_factor_prior_std=args.viscosity_prior_std
    )
    ekf = OilFlowEKF(model, config)
    steps = round(args.duration_s / 1e-3)
    estimate, std, alarm = np.zeros((steps, 2)), np.zeros((steps, 2)), np.zeros((steps, 2), dtype=bool)
    for k in range(steps):
        s, t = float(speed(k * 1e-3)), float(temperature(k * 1e-3))
        report = ekf.step(plant.step(tuple(q), speed_hz=s, oil_temperature_c=t).measured_position_m, s, t)
        estimate[k], std[k], alarm[k] = report.q_m3_s, report.q_std_m3_s, report.starved
    last = slice(steps - 5000, steps)
    error = 100.0 * (estimate[last].mean(axis=0) - q) / q
    print(
        f"q = {tuple(args.q_pct)} %, plant film factor {args.plant_viscosity_factor:g}, factor prior std "
        f"{args.viscosity_prior_std:g}: errors {error[0]:+.3f} / {error[1]:+.3f} %, std "
        f"{100 * std[last, 0].mean() / q[0]:.2f} / {100 * std[last, 1].mean() / q[1]:.2f} %, alarm samples "
        f"after 2 s {alarm[2000:].sum(axis=0).tolist()}, factors "
        f"{np.round(ekf.viscosity_factor, 4).tolist()} +- {np.round(ekf.viscosity_factor_std, 4).tolist()}, "
        f"{model.recentre_count} re-centrings"
    )


if __name__ == "__main__":
    main()
