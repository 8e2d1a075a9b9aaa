"""Model error of the estimator's operating-point model against exact maps (issue 13, estimator side).

For operating points along the issue's ramps (speed 72-78 Hz, oil +0..+10 degC, viscosity factors 0.95-1.05)
and flowrates (100/100, 80/90 % of nominal), the correction's centre is put a given fraction of the
re-centring thresholds away in every axis (fraction 1: where a step re-centres once 200 steps have passed;
up to 4, the hard limit, within those steps; the centre is held there whatever the fraction), and the
model's static shaft position and 1x orbit are compared with those of the exact map on the dimensionless
table at the same point. Errors in um and in equivalent % of flow (the static y sensitivity, um per % of q).
``--first-order``: the correction without its second-order terms; ``--flow-viscosity-only``: the centre at
the point's speed (offset in the flowrates and viscosities only, where the estimate wanders).

    python scripts/operating_model_error.py [--fraction 1.0] [--first-order] [--flow-viscosity-only]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.operating_model import (
    REFERENCE_TABLES,
    OperatingAugmentedModel,
    Recentring,
    build_operating_model,
    map_response,
)

CASES = (
    # speed [Hz], oil temperature over nominal [degC], viscosity factors, flowrates [fraction of nominal]
    (75.0, 0.0, (1.0, 1.0), (1.0, 1.0)),
    (72.0, 0.0, (1.0, 1.0), (1.0, 1.0)),
    (78.0, 10.0, (1.0, 1.0), (1.0, 1.0)),
    (78.0, 10.0, (1.0, 1.0), (0.8, 0.9)),
    (72.0, 5.0, (1.05, 0.95), (0.8, 0.9)),
    (60.0, -5.0, (1.0, 1.0), (1.0, 1.0)),
)


def model_errors(model, speed_hz, temperature_c, factors, q, fraction, speed_axis=True):
    """(static error um, orbit error um) of the model against the exact map, max over the 4 probes."""
    model.set_operating_point(speed_hz, temperature_c)
    exact = map_response(model, *model.exact_map(q, factors), speed_hz)
    r = model.recentring
    shift = fraction * np.array(
        [
            -r.flowrate_fraction * model.nominal_flowrate_m3_s,
            r.flowrate_fraction * model.nominal_flowrate_m3_s,
            -r.speed_fraction * model.speed_hz if speed_axis else 0.0,
            r.log_viscosity,
            -r.log_viscosity,
        ]
    )
    log_mu = np.log(model.operating_point[1] * np.asarray(factors))
    model.place_centre(np.concatenate([q, [speed_hz], log_mu]) + shift)
    approx = map_response(model, *model.discrete_map(q, factors), speed_hz)
    return float(np.abs(approx[0] - exact[0]).max()), float(np.abs(approx[1] - exact[1]).max())


def held_model(
    model: OperatingAugmentedModel, thresholds: Recentring | None = None, **options
) -> OperatingAugmentedModel:
    """``model``'s grid and maps with ``thresholds``' (default: the default) thresholds but a centre that
    never moves by itself."""
    held = dataclasses.replace(thresholds or Recentring(), hard_factor=math.inf, min_interval_steps=2**62)
    return OperatingAugmentedModel(
        model.reference, model.maps, model.oil, model.reference_viscosity_pa_s, held, **options
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fraction", type=float, default=1.0, help="centre offset in thresholds")
    parser.add_argument("--reference-table", default="dimensionless", choices=REFERENCE_TABLES)
    parser.add_argument("--first-order", action="store_true", help="no second-order terms")
    parser.add_argument("--flow-viscosity-only", action="store_true", help="no speed offset")
    args = parser.parse_args()
    machine = load_machine()
    system = load_system(reduced=True)
    model = held_model(build_operating_model(system, machine, reference_table=args.reference_table))
    if args.first_order:
        model = held_model(model, second_order=())
    qn = system.nominal_flowrate_m3_s
    t0 = machine.nominal_oil_temperature_c
    base = map_response(model, *model.reference.system.discrete_map((qn, qn), model.dt_s), 75.0)
    step = map_response(model, *model.reference.system.discrete_map((1.01 * qn, qn), model.dt_s), 75.0)
    per_pct = float(abs(step[0][1] - base[0][1]))
    print(f"static y1 sensitivity {per_pct:.4f} um per % of q1 (nominal)")
    header = ("speed Hz", "dT degC", "f1,f2", "q %", "static um", "orbit um", "~% q")
    print(" ".join(f"{h:>{w}}" for h, w in zip(header, (8, 7, 10, 9, 10, 9, 6), strict=True)))
    for speed, dt, factors, fractions in CASES:
        q = np.array(fractions) * qn
        static, orbit = model_errors(
            model, speed, t0 + dt, factors, q, args.fraction, not args.flow_viscosity_only
        )
        print(
            f"{speed:8.1f} {dt:7.1f} {factors[0]:4.2f},{factors[1]:4.2f} "
            f"{fractions[0] * 100:4.0f}/{fractions[1] * 100:3.0f} {static:10.4f} {orbit:9.4f} "
            f"{static / per_pct:6.2f}"
        )


if __name__ == "__main__":
    main()
