"""What the operating model's re-centrings cost on the free-factor ramp rows of the robustness report.

For each ``--cases`` row at 100/100 (the report's settings and record: its plant motion from
``--motion-cache``, kept there by the first run, with the report's noise draw,
seed 1), the row's estimator (the start bank, fed the measured speed and oil temperature) runs the 60 s
record.
Printed per pass: the process CPU of the run, the re-centrings (every filter's, counted by wrapping
``OperatingAugmentedModel._recentre``) per minute of record and their median CPU each. Run it once per tree
on ``PYTHONPATH`` (e.g. a baseline from ``git archive``), alternating, for a same-run ratio::

    OPENBLAS_NUM_THREADS=1 python benchmarks/ramp_recentring.py --motion-cache DIR [--repeats 2] \\
        [--duration-s 60]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from oilwatch.models.system import operating_model
from oilwatch.models.system.measurement import MeasurementChain
from oilwatch.robustness.case_run import DT_S, RobustnessRun
from oilwatch.robustness.cases import case_by_name
from oilwatch.robustness.runner import REPORT_SETTINGS


def plant_motion(run: RobustnessRun, case, point, cache: Path | None):
    """(true (K, 4), rotor angle (K,), times (K,)) of the case's plant, from ``cache`` when there."""
    name = f"{case.name}_{point[0]:g}_{point[1]:g}_{run.duration_s:g}s_motion.npz"
    path = None if cache is None else cache / name
    if path is not None and path.exists():
        data = np.load(path)
        return data["true"], data["angle"], data["clock"]
    true, angle, clock = run.true_motion(case, point, run.seed)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, true=true, angle=angle, clock=clock)
    return true, angle, clock


def measured(run: RobustnessRun, case, true, angle, clock, seed: int | None) -> np.ndarray:
    """The case's probes on ``true``: noise from ``default_rng(seed)`` as the plant draws it (None: none)."""
    chain = run.chain(case, True)
    if seed is None:
        chain = MeasurementChain(chain.probes, chain.mounting_angle_rad, 0.0)
    rng, held = np.random.default_rng(run.seed if seed is None else seed), np.zeros(4)
    return np.array([chain.measure(true[k], angle[k], clock[k], rng, held) for k in range(len(clock))])


def counted_recentring() -> list[float]:
    """Wrap the model's re-centring: the returned list gets each call's process CPU [s]."""
    costs: list[float] = []
    original = operating_model.OperatingAugmentedModel._recentre

    def recentre(self, point):
        start = time.process_time()
        original(self, point)
        costs.append(time.process_time() - start)

    operating_model.OperatingAugmentedModel._recentre = recentre
    return costs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--motion-cache", type=Path, required=True)
    parser.add_argument("--cases", nargs="+", default=["speed-ramp", "temperature-ramp"])
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--duration-s", type=float, default=REPORT_SETTINGS["duration_s"], help="record [s]")
    args = parser.parse_args()
    costs = counted_recentring()
    run = RobustnessRun({**REPORT_SETTINGS, "duration_s": args.duration_s})
    print(f"tree {Path(operating_model.__file__).resolve().parents[2]}")
    for name in args.cases:
        case, point = case_by_name(name), (100.0, 100.0)
        true, angle, clock = plant_motion(run, case, point, args.motion_cache)
        times = DT_S * np.arange(1, len(clock) + 1)
        speed = np.array([run.speed_hz(case, t - DT_S) for t in times])
        temperature = np.array([run.temperature_c(case, t - DT_S) for t in times])
        record = measured(run, case, true, angle, clock, run.seed)
        config = run.config(case)
        run.estimate(case, config, record[:200], speed[:200], temperature[:200])  # compile, build
        minutes = len(record) * DT_S / 60.0
        for _ in range(args.repeats):
            costs.clear()
            start = time.process_time()
            trace, _ = run.estimate(case, config, record, speed, temperature)
            total = time.process_time() - start
            error = 100.0 * (trace.q_m3_s[len(record) // 2 :].mean(axis=0) / (run.nominal_m3_s) - 1.0)
            print(
                f"{name} 100/100: run {total:.1f} s CPU, {len(costs) / minutes:.0f} re-centrings per "
                f"minute, {1e3 * np.median(costs):.2f} ms CPU each (median), "
                f"{100 * sum(costs) / total:.0f} % of the run; error {error[0]:+.2f} / {error[1]:+.2f} %",
                flush=True,
            )


if __name__ == "__main__":
    main()
