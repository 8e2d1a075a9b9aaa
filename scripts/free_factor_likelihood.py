"""Is the free-factor ramp rows' wrong end point a local optimum of the record's likelihood, or the EKF's?

For one cached robustness record (``RECORDS/<case>_<q1>_<q2>_60.npz``, the robustness
plant's measured samples, speed and oil temperature) this runs the row's filter (viscosity factors free,
no baseline) from its nominal start, and as a diagnostic from ``q_initial`` at the case's truth point (the
only use of the truth: to get the other end point to compare; never a start of the method). Each run's
parameters (flowrates, factors, unbalance, offsets) averaged over the last 30 s are then held FIXED in
the same filter (their covariance and random walks ~0, so it is a Kalman filter of the dynamic states
only) and the record's innovation statistics are summed: the filter model's likelihood of a constant
parameter vector, up to the log-determinant of the innovation covariance, which is the same to first
order for nearby parameters (reported: summed NIS and updates). A likelihood profile along the segment
between the two points (fractions ``--along``) tells a barrier (a local optimum) from a slope.

    python scripts/free_factor_likelihood.py temperature-ramp 80 90
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.robustness.cases import case_by_name
from oilwatch.robustness.runner import REPORT_SETTINGS, RobustnessRun

SETTINGS = REPORT_SETTINGS
TINY = 1e-9


def parameters(ekf: OilFlowEKF) -> np.ndarray:
    """(q1, q2 [m^3/s], factors (2), unbalance (2), offsets (4) [m]) now."""
    x, layout, nominal = ekf.get_state()["x"], ekf.state_layout, ekf.config.q_nominal_m3_s
    n = layout.n
    return np.r_[x[n : n + 2] * nominal, x[layout.viscosity], x[layout.unbalance], x[layout.offsets]]


def fix_parameters(ekf: OilFlowEKF, fixed: np.ndarray) -> None:
    """Put the parameters (in :func:`parameters`' order) into the filter's state."""
    state, layout = ekf.get_state(), ekf.state_layout
    x, n = state["x"], layout.n
    x[n : n + 2] = fixed[:2] / ekf.config.q_nominal_m3_s
    x[layout.viscosity] = fixed[2:4]
    x[layout.unbalance] = fixed[4:6]
    x[layout.offsets] = fixed[6:10]
    ekf.set_state(state)


def run(model, config, record, keep_from: int, fixed: np.ndarray | None = None):
    """(mean parameters over the samples from ``keep_from``, summed NIS before and from ``keep_from``,
    updates before and from it)."""
    signals, speed, temperature = record
    ekf = OilFlowEKF(model, config)
    if fixed is not None:
        fix_parameters(ekf, fixed)
    kept, nis, updates = [], np.zeros(2), np.zeros(2, dtype=int)
    for k in range(len(signals)):
        report = ekf.step(signals[k], speed_hz=float(speed[k]), oil_temperature_c=float(temperature[k]))
        late = k >= keep_from
        if late:
            kept.append(parameters(ekf))
        nis[int(late)] += report.nis
        updates[int(late)] += report.n_measurements > 0
    return np.mean(kept, axis=0), nis, updates


def fixed_config(config, nominal_m3_s: float):
    """The same filter with every parameter held where it is put (a Kalman filter of the motion)."""
    return dataclasses.replace(
        config,
        flowrate_process_std_m3_s=0.0,
        initial_flowrate_std_m3_s=TINY * nominal_m3_s,
        viscosity_factor_prior_std=TINY,
        viscosity_factor_random_walk_sqrt_s=0.0,
        unbalance_prior_std=TINY,
        unbalance_random_walk_sqrt_s=0.0,
        offset_prior_std_m=TINY * 1e-6,
        offset_random_walk_m_sqrt_s=0.0,
        change_flowrate_std_fraction=0.0,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("case")
    parser.add_argument("q1", type=float)
    parser.add_argument("q2", type=float)
    parser.add_argument("--along", type=float, nargs="*", default=[0.0, 0.5, 1.0])
    parser.add_argument("--records", required=True, help="folder of the cached robustness records")
    args = parser.parse_args()
    case = case_by_name(args.case)
    runner = RobustnessRun(SETTINGS)
    data = np.load(f"{args.records}/{args.case}_{args.q1:g}_{args.q2:g}_60.npz")
    record = (data["measured"], data["speed"], data["temperature"])
    model = runner.operating_model()
    config = runner.config(case)
    half = len(record[0]) // 2
    truth = np.array([args.q1, args.q2]) / 100.0 * runner.nominal_m3_s
    ends = {}
    for label, start in (("nominal start", None), ("start at truth q (diagnostic)", tuple(truth))):
        began = time.process_time()
        cfg = config if start is None else dataclasses.replace(config, q_initial_m3_s=start)
        theta, nis, updates = run(model, cfg, record, half)
        ends[label] = theta
        print(
            f"{label}: q err {100 * (theta[:2] / truth - 1)} % factors {theta[2:4]} unbalance {theta[4:6]} "
            f"offsets {theta[6:] * 1e6} um; free filter's NIS sums {nis.round(1)} / {updates} "
            f"({time.process_time() - began:.0f} s CPU)"
        )
    a, b = ends.values()
    fixed = fixed_config(config, runner.nominal_m3_s)
    for fraction in args.along:
        theta = a + fraction * (b - a)
        _, nis, updates = run(model, fixed, record, half, fixed=theta)
        print(
            f"fixed at {fraction:.2f} of the way nominal-end -> truth-start-end: q err "
            f"{100 * (theta[:2] / truth - 1)} %: NIS sums (first, last 30 s) {nis.round(1)} over "
            f"{updates} updates"
        )


if __name__ == "__main__":
    main()
