"""Which 1 kHz data gives the right starvation alarm from a 5 kHz record: every 5th sample (what the
estimator FMU takes in a co-simulation at 1 kHz) or the anti-alias filtered samples (what ``oilwatch
estimate`` takes)?

One in-process plant run at 5 kHz (full-order Newmark plant, bearing 1 dropping to 75 % along a sigmoid
centred at ``--drop-s``), noise-free, read along probes at ``--probe-angle-deg`` with the zero offsets
``--offsets-um`` added; then, for each seed, fresh white probe noise of ``--noise-um`` at 5 kHz. The
estimator (``oilwatch estimate``'s configuration: the machine file's 25 um probe-offset prior) runs on (a)
every 5th noisy sample, (b) the anti-aliased noisy samples (:class:`oilwatch.records.signal.GridResampler`,
as the command) and (c) every 5th noise-free sample: the alarm that the data's noise did not move. Printed
per noise level: each path's alarm-time error against (c) (mean, std, largest), the noise std at the
estimator's input, and each path's RMS flowrate error against the truth after the start-up.

    python scripts/alarm_decimation.py [--seeds 8] [--noise-um 0.05 0.3 1] [--offsets-um 12 -8 15 -18]
                                       [--probe-angle-deg 45]
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

import numpy as np

RATIO = 5
DT_S = 1e-3


def alarm_time(trace, times: np.ndarray) -> float:
    starved = trace.starved[:, 0]
    return float(times[np.argmax(starved)]) if starved.any() else float("nan")


def main() -> None:
    from fixtures.plant_records import plant_run

    from oilwatch.estimator.config import ML_MIN
    from oilwatch.estimator.ekf import OilFlowEKF
    from oilwatch.estimator.measurement import probe_rotation
    from oilwatch.models.machine import load_machine
    from oilwatch.models.probes import read_probes
    from oilwatch.monitoring.estimate import estimator_config, estimator_model
    from oilwatch.records.signal import GridResampler

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--noise-um", type=float, nargs="+", default=[0.05, 0.3, 1.0])
    parser.add_argument("--duration-s", type=float, default=3.0)
    parser.add_argument("--drop-s", type=float, default=1.5)
    parser.add_argument("--drop-width-s", type=float, default=0.1, help="the sigmoid's width parameter")
    parser.add_argument(
        "--offsets-um", type=float, nargs=4, default=[0.0] * 4, help="probe zero offsets x1 y1 x2 y2 [um]"
    )
    parser.add_argument(
        "--probe-angle-deg",
        type=float,
        default=0.0,
        help="probe pairs' angle (45: API 670), readings along them",
    )
    args = parser.parse_args()

    t, true, _, q = plant_run(
        args.duration_s, DT_S / RATIO, 0.0, drop_at_s=args.drop_s, drop_width_s=args.drop_width_s
    )
    true = true @ probe_rotation(np.radians(args.probe_angle_deg)).T + np.array(args.offsets_um) * 1e-6
    grid_t = t[RATIO - 1 :: RATIO]
    truth = q[RATIO - 1 :: RATIO]
    probes = read_probes(load_machine())
    model = estimator_model(None)

    def estimate(samples: np.ndarray, noise_um: float):
        ekf = OilFlowEKF(
            model, estimator_config(75.0, noise_um, 0.0, probes, probe_angle_deg=args.probe_angle_deg)
        )
        ekf.step(np.full(4, np.nan))  # the first sample at t = dt, as the FMU started at t = 0
        return ekf.run(samples)

    def anti_aliased(samples: np.ndarray) -> np.ndarray:
        resampler = GridResampler(RATIO / DT_S, DT_S, np.ones(4, dtype=bool))
        k, grid = resampler.push(t, samples)
        assert np.array_equal(k, np.arange(1, k.size + 1)), "grid starts at t = dt"
        return grid  # the last (taps - 1) / 2 input samples are still in the filter: a shorter record

    settled = grid_t > 0.5
    for noise in args.noise_um:
        reference = estimate(true[RATIO - 1 :: RATIO], noise)
        t0 = alarm_time(reference, grid_t)
        errors = {"every 5th (FMU)": [], "anti-aliased (estimate)": []}
        rms = {name: [] for name in errors}
        input_noise = []
        for seed in range(args.seeds):
            rng = np.random.default_rng(1000 + seed)
            noisy = true + rng.normal(0.0, noise * 1e-6, true.shape)
            filtered = anti_aliased(noisy)
            input_noise.append(float(np.std(filtered - anti_aliased(true))) * 1e6)
            paths = (("every 5th (FMU)", noisy[RATIO - 1 :: RATIO]), ("anti-aliased (estimate)", filtered))
            for name, data in paths:
                trace = estimate(data, noise)
                n = data.shape[0]
                errors[name].append(alarm_time(trace, grid_t[:n]) - t0)
                gap = trace.q_m3_s[settled[:n], 0] / ML_MIN - truth[:n][settled[:n], 0]
                rms[name].append(float(np.sqrt(np.mean(gap**2))))
        print(
            f"noise {noise:g} um at 5 kHz: noise-free alarm at {t0:.3f} s; noise at the estimator's input: "
            f"every 5th {noise:g} um, anti-aliased {np.mean(input_noise):.3f} um"
        )
        for name, values in errors.items():
            e = np.array(values) * 1e3
            print(
                f"  {name:24s} alarm - noise-free alarm: mean {np.nanmean(e):+6.1f} ms, "
                f"std {np.nanstd(e):5.1f} "
                f"ms, largest |.| {np.nanmax(np.abs(e)):5.1f} ms; RMS q1 error after 0.5 s "
                f"{np.mean(rms[name]):.3f} ml/min"
            )


if __name__ == "__main__":
    main()
