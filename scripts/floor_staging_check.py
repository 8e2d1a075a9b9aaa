"""The information floor's staged update against a tree from before it: the same estimates, stds and alarms.

Runs one filter with the viscosity factors estimated over the first ``--samples`` of
``benchmarks/ekf_step.py``'s 60 s plant ramp record and saves the flowrates, the reported stds and the
alarms; ``--compare A B`` prints how many samples differ between two such files. Run it once in this tree
and once with ``PYTHONPATH`` on the other tree's checkout (``--robustness``: the robustness report's
temperature-ramp configuration instead of ``ekf_step.py``'s) (``git archive d733c26 | tar -x -C DIR``):

    python scripts/floor_staging_check.py new.npz
    PYTHONPATH=DIR python scripts/floor_staging_check.py old.npz
    python scripts/floor_staging_check.py --compare old.npz new.npz
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def run(out: str, samples: int, robustness: bool) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
    from ekf_step import plant_ramp_record

    from oilwatch.estimator.config import EKFConfig
    from oilwatch.estimator.ekf import OilFlowEKF
    from oilwatch.models.machine import load_machine
    from oilwatch.models.system.factory import load_system
    from oilwatch.models.system.operating_model import build_operating_model

    model = build_operating_model(load_system(reduced=True), load_machine())
    ramp, speed, temperature = (a[:samples] for a in plant_ramp_record(60.0))
    config = EKFConfig.recommended(viscosity_factor_prior_std=0.05, first_sample_time_s=1e-3)
    if robustness:  # the robustness report's temperature-ramp configuration (offsets, unbalance, factors 0.1)
        from oilwatch.robustness.cases import case_by_name
        from oilwatch.robustness.runner import REPORT_SETTINGS, RobustnessRun

        config = RobustnessRun(REPORT_SETTINGS).config(case_by_name("temperature-ramp"))
    trace = OilFlowEKF(model, config).run(ramp, speed_hz=speed, oil_temperature_c=temperature)
    np.savez(out, q=trace.q_m3_s, std=trace.q_std_m3_s, starved=trace.starved)


def compare(old: str, new: str) -> None:
    a, b = np.load(old), np.load(new)
    for name in ("q", "std", "starved"):
        differ = np.flatnonzero((a[name] != b[name]).reshape(len(a[name]), -1).any(axis=1))
        print(
            f"{name}: {differ.size} of {len(a[name])} samples differ"
            + (f", first {differ[:5]}" if differ.size else "")
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", help="the .npz to write")
    parser.add_argument("--samples", type=int, default=60000)
    parser.add_argument("--robustness", action="store_true", help="the robustness report's configuration")
    parser.add_argument("--compare", nargs=2, metavar=("OLD", "NEW"))
    args = parser.parse_args()
    if args.compare:
        compare(*args.compare)
    elif args.out:
        run(args.out, args.samples, args.robustness)
    else:
        parser.error("give OUT or --compare OLD NEW")


if __name__ == "__main__":
    main()
