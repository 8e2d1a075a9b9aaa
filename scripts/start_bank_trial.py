"""The start bank's members on the cached robustness records: each member's accumulated NIS since the
settling restart at checkpoints, and its end error (mean of the last 30 s): which start each selection window
would keep, and what it reads. Diagnostic (the truth is used only to print the errors).

    python scripts/start_bank_trial.py temperature-ramp 80 90
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from oilwatch.estimator.start_bank import START_FRACTIONS, StartBank
from oilwatch.robustness.cases import Case, case_by_name
from oilwatch.robustness.runner import REPORT_SETTINGS, RobustnessRun

SETTINGS = REPORT_SETTINGS
CHECKPOINTS_S = (5.0, 10.0, 15.0, 20.0, 30.0, 60.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("case", help="a robustness case, or 'const' (free factors at constant conditions)")
    parser.add_argument("q1", type=float)
    parser.add_argument("q2", type=float)
    parser.add_argument("--records", required=True, help="folder of the cached robustness records")
    args = parser.parse_args()
    if args.case == "const":
        case = Case("const", "free factors, constant conditions", operating_point=True)
    else:
        case = case_by_name(args.case)
    runner = RobustnessRun(SETTINGS)
    data = np.load(f"{args.records}/{args.case}_{args.q1:g}_{args.q2:g}_60.npz")
    signals, speed, temperature = data["measured"], data["speed"], data["temperature"]
    began = time.process_time()
    bank = StartBank(runner.operating_model(), runner.config(case), select_s=np.inf)
    marks = {round(t / 1e-3): t for t in CHECKPOINTS_S}
    truth = np.array([args.q1, args.q2]) / 100.0 * runner.nominal_m3_s
    half = len(signals) // 2
    sums = np.zeros((len(bank.filters), 2))
    for k in range(len(signals)):
        reports = [
            ekf.step(signals[k], speed_hz=float(speed[k]), oil_temperature_c=float(temperature[k]))
            for ekf in bank.filters
        ]
        for m, report in enumerate(reports):
            if k > bank.settling_steps:
                bank.nis[m] += report.nis
            if k >= half:
                sums[m] += report.q_m3_s
        if k + 1 in marks:
            nis = bank.nis - bank.nis.min()
            print(
                f"t = {marks[k + 1]:4.0f} s: NIS above the least {np.round(nis, 1)} -> start "
                f"{START_FRACTIONS[int(np.argmin(bank.nis))]}"
            )
    for m, f in enumerate(START_FRACTIONS):
        error = 100.0 * (sums[m] / (len(signals) - half) / truth - 1.0)
        print(f"start {f:.1f} x nominal: error {error[0]:+.2f} / {error[1]:+.2f} %")
    print(f"{time.process_time() - began:.0f} s CPU")


if __name__ == "__main__":
    main()
