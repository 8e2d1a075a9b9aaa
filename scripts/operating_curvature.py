"""The operating model's second-order terms: their finite-difference step, and which axis pairs matter.

1. The second derivatives of ``(A_d, G)`` along the correction's axis pairs at one operating point (77 Hz,
   viscosities 0.62 / 0.60 of nominal, flowrates 80 / 90 %), as forward differences of the exact first
   derivatives with steps 1e-5 to 1e-2 (``OperatingMaps.second_derivatives``), each against central
   differences of 3e-4 and 1e-3 (relative error, max over the matrices' entries): truncation against
   round-off.
2. The model error (``scripts/operating_model_error.py``: static position and 1x orbit of the map against
   the exact map's, worst probe, over its operating points) with the centre F thresholds away in every axis
   (d323c00's thresholds: 2 % of speed, 0.03 in ln mu, 1.5 % of flow),
   for the correction of first order, with each bearing's own (q_b, ln mu_b) second-order terms (the
   model's), with the cross-bearing pairs added, and with the speed's pairs added as well.

    python scripts/operating_curvature.py [--fractions 1 2 4]
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from operating_model_error import CASES, held_model, model_errors

from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import load_system
from oilwatch.models.system.operating_correction import SECOND_ORDER_PAIRS
from oilwatch.models.system.operating_maps import AXES
from oilwatch.models.system.operating_model import Recentring, build_operating_model

CROSS_PAIRS = ((0, 1), (3, 4), (0, 4), (1, 3))
"""Second-order pairs across the bearings: (q1, q2), (ln mu1, ln mu2), (q1, ln mu2), (q2, ln mu1)."""
SPEED_PAIRS = ((2, 2), (0, 2), (1, 2), (2, 3), (2, 4))
"""Second-order pairs with the speed."""
PREVIOUS = Recentring(speed_fraction=0.02, log_viscosity=0.03, flowrate_fraction=0.015)
"""d323c00's thresholds, the distances of the pair study."""


def central(maps, q, speed, mu, pair, step):
    """The second derivative along ``pair`` by a central difference of the first derivatives."""
    i, j = pair
    ends = []
    for sign in (+1, -1):
        q_s, speed_s, mu_s, coordinate = maps.shifted_point(AXES[i], q, speed, mu, sign, step)
        _, _, d_a, _ = maps.derivatives(q_s, speed_s, mu_s, (AXES[j],))
        ends.append((d_a[0], coordinate))
    return (ends[0][0] - ends[1][0]) / (ends[0][1] - ends[1][1])


def step_study(model) -> None:
    maps = model.maps
    q = np.array([0.8, 0.9]) * model.nominal_flowrate_m3_s
    mu = model.reference_viscosity_pa_s * np.array([0.62, 0.60])
    speed = 77.0
    _, _, d_a, d_g = maps.derivatives(q, speed, mu)
    pairs = SECOND_ORDER_PAIRS
    names = [f"{AXES[i]},{AXES[j]}" for i, j in pairs]
    references = {h: [central(maps, q, speed, mu, pair, h) for pair in pairs] for h in (3e-4, 1e-3)}
    print("forward-difference step against central differences: relative error per pair " + " ".join(names))
    for step in (1e-5, 1e-4, 1e-3, 1e-2):
        second, _ = maps.second_derivatives(q, speed, mu, pairs, (d_a, d_g), step=step)
        for h, reference in references.items():
            errors = [np.abs(s - r).max() / np.abs(r).max() for s, r in zip(second, reference, strict=True)]
            print(f"  step {step:.0e} vs central {h:.0e}: " + " ".join(f"{e:.1e}" for e in errors))


def pair_study(model, fractions) -> None:
    variants = {
        "first order": (),
        "own bearing (model)": SECOND_ORDER_PAIRS,
        "+ cross-bearing": SECOND_ORDER_PAIRS + CROSS_PAIRS,
        "+ speed": SECOND_ORDER_PAIRS + CROSS_PAIRS + SPEED_PAIRS,
    }
    machine = load_machine()
    t0 = machine.nominal_oil_temperature_c
    qn = model.nominal_flowrate_m3_s
    print("worst static / orbit error [um] over the operating points, centre F thresholds away")
    for fraction in fractions:
        for name, pairs in variants.items():
            variant = held_model(model, PREVIOUS, second_order=pairs)
            worst = np.zeros(2)
            rows = []
            for speed, dt, factors, share in CASES:
                errors = model_errors(variant, speed, t0 + dt, factors, np.array(share) * qn, fraction)
                rows.append(f"{errors[0]:.4f}/{errors[1]:.4f}")
                worst = np.maximum(worst, errors)
            print(
                f"  F = {fraction:g} {name:>20}: worst {worst[0]:.4f} / {worst[1]:.4f}; rows "
                + " ".join(rows)
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fractions", type=float, nargs="+", default=[1.0, 2.0, 4.0])
    args = parser.parse_args()
    model = held_model(build_operating_model(load_system(reduced=True), load_machine()))
    step_study(model)
    pair_study(model, args.fractions)


if __name__ == "__main__":
    main()
