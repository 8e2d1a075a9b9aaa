"""Worst-case step latency of the estimator with the viscosity factors estimated (``ekf_step.py --latency``).

Per-step thread CPU time over one pass of ``ekf_step.py``'s plant ramp record (``--ramp-s``, 60 s): one
filter, and :func:`oilwatch.estimator.factory.make_estimator`'s start bank (what ``oilwatch estimate`` and the
FMU run: five filters for its first 20 s). Printed: median, p99, p99.9, max, the steps over 1 ms (a missed
deadline at 1 kHz) and the mean. The worst steps are the information floor's updates (every 2 s) and the
operating model's re-centrings. Thread CPU time: a step preempted by the shared machine's load does not
count its wait.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from ekf_step_ramps import plant_ramp_record

from oilwatch import estimator
from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import load_system


def step_latency_us(estimator, record: np.ndarray, speed: np.ndarray, temperature: np.ndarray):
    """((K,) thread CPU time of each of the K steps of ``estimator`` over the record [us], (K,) bool: the
    step re-centred an operating model). A step preempted by the shared machine's load does not count its
    wait."""
    clock = time.thread_time_ns
    models = [ekf.model for ekf in getattr(estimator, "filters", [estimator])]
    step, costs = estimator.step, np.empty(len(record))
    recentred = np.zeros(len(record), dtype=bool)
    count = sum(m.recentre_count for m in models)
    for k, (z, s, t) in enumerate(zip(record, speed.tolist(), temperature.tolist(), strict=True)):
        start = clock()
        step(z, s, t)
        costs[k] = clock() - start
        now = sum(m.recentre_count for m in models)
        recentred[k], count = now > count, now
    return costs * 1e-3, recentred


def latency_rows(args) -> None:
    """Print the latency figures (module docstring)."""
    from oilwatch.models.system.operating_model import build_operating_model

    model = build_operating_model(load_system(reduced=True), load_machine())
    ramp, speed, temperature = plant_ramp_record(args.ramp_s)
    factors = EKFConfig.recommended(viscosity_factor_prior_std=0.05, first_sample_time_s=1e-3)
    builders = [("one filter", lambda: OilFlowEKF(model, factors))]
    if (Path(estimator.__file__).parent / "factory.py").exists():  # not in a baseline tree from before it
        from oilwatch.estimator.factory import make_estimator

        builders.append(("make_estimator (the start bank)", lambda: make_estimator(model, factors)))
    OilFlowEKF(model, factors).run(ramp[:10], speed_hz=speed[:10], oil_temperature_c=temperature[:10])
    print(f"per-step thread CPU [us], viscosity factors estimated, {args.ramp_s:g} s plant ramps")
    print(f"{'estimator':<44} {'median':>8} {'p99':>8} {'p99.9':>8} {'max':>9} {'> 1 ms':>7} {'mean':>8}")
    for name, build in builders:
        costs, recentred = step_latency_us(build(), ramp, speed, temperature)
        for part, chosen in (("", slice(None)), ("  without re-centrings", ~recentred)):
            median, p99, p999 = np.percentile(costs[chosen], [50.0, 99.0, 99.9])
            print(
                f"{name + part:<44} {median:8.1f} {p99:8.1f} {p999:8.1f} {costs[chosen].max():9.1f} "
                f"{int((costs[chosen] > 1000.0).sum()):7d} {costs[chosen].mean():8.1f}"
            )
        print(f"  re-centring steps: {int(recentred.sum())}, median {np.median(costs[recentred]):.0f} us")
        if name.startswith("make"):
            window = round(20.0 / 1e-3)
            print(f"  median of the first 20 s (the window): {np.median(costs[:window]):.1f} us")
    print()
