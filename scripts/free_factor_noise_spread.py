"""A robustness row's estimator on its plant's motion with other noise draws: model error or noise?

    OPENBLAS_NUM_THREADS=1 python scripts/free_factor_noise_spread.py speed-ramp 100 100 --seeds 1-17 \
        [--own-model] [--single-start] [--motion-cache DIR] [--recentring SPEED LOG_MU FLOW MIN_STEPS]

The plant's true motion of the case (``RobustnessRun.true_motion``: the report's settings, seed 1) is
simulated once; the case's probes (offsets, angle) are applied to it as ``RobustnessRun.record`` does, with
the measurement noise drawn from each ``--seeds`` generator (seed 1 is the report's record, bit for bit) and
once without noise. Each record goes through the row's estimator (``RobustnessRun.estimate``: the start
bank where it applies, fed the measured speed and oil temperature), and the row's figure is printed: the
error of the mean of the last 30 s [% of the truth]. ``--own-model`` replaces the plant's motion with
the estimator's own operating model (default thresholds) run at the truth (factors 1, the case's
unbalance) along the same speed and temperature, from rest (the first second is its settling): the same
noise draws on a record without any plant/model difference. ``--recentring`` builds the estimator's
operating model with these thresholds of :class:`oilwatch.models.system.operating_model.Recentring` (speed and
flowrate as fractions of nominal, ln mu, the least steps between re-centrings) instead of the defaults.
``--single-start`` runs the configured start's filter alone (the start bank's member 1.0) where the row
runs the bank.

Reading: the noise-free record's error is the bias the model difference gives; the spread over seeds is
the estimator's variance on this record's information, to compare with its reported std; the mean over
seeds minus the noise-free error is a bias the noise itself gives the estimator. Diagnostic: the truth is
used only to make the records and to print the errors.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from oilwatch.models.system.factory import build_system
from oilwatch.models.system.measurement import MeasurementChain
from oilwatch.models.system.operating_model import Recentring, build_operating_model
from oilwatch.robustness.cases import case_by_name
from oilwatch.robustness.runner import DT_S, REPORT_SETTINGS, RobustnessRun


def seeds_of(text: str) -> list[int]:
    """``"1-5,9"`` -> [1, 2, 3, 4, 5, 9]."""
    seeds = []
    for part in text.split(","):
        low, _, high = part.partition("-")
        seeds.extend(range(int(low), int(high or low) + 1))
    return seeds


def plant_motion(run: RobustnessRun, case, point, cache: Path | None):
    """(true (K, 4), rotor angle (K,), times (K,)) of the case's plant, from ``cache`` when there."""
    path = None if cache is None else cache / f"{case.name}_{point[0]:g}_{point[1]:g}_motion.npz"
    if path is not None and path.exists():
        data = np.load(path)
        return data["true"], data["angle"], data["clock"]
    true, angle, clock = run.true_motion(case, point, run.seed)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, true=true, angle=angle, clock=clock)
    return true, angle, clock


def own_model_motion(run: RobustnessRun, case, point, speed, temperature) -> np.ndarray:
    """(K, 4) the estimator's operating model at the truth along the record's speed and temperature."""
    model = run.operating_model()
    truth = np.array(point) / 100.0 * run.nominal_m3_s
    factors, unbalance = np.full(2, case.viscosity_factor), np.array([case.unbalance[0], 0.0])
    model.reset_operating_state()
    state, true = np.zeros(model.n_states), np.zeros((len(speed), 4))
    for j in range(len(speed)):
        model.set_operating_point(float(speed[j]), float(temperature[j]))
        state = np.array(model.transition_full(state, truth, j, factors, unbalance)[0])
        true[j] = model.output_matrix @ state
    model.reset_operating_state()
    return true


def measured(run: RobustnessRun, case, true, angle, clock, seed: int | None) -> np.ndarray:
    """The case's probes on ``true``: noise from ``default_rng(seed)`` as the plant draws it (None: none)."""
    chain = run.chain(case, True)
    if seed is None:
        chain = MeasurementChain(chain.probes, chain.mounting_angle_rad, 0.0)
    rng, held = np.random.default_rng(run.seed if seed is None else seed), np.zeros(4)
    return np.array([chain.measure(true[k], angle[k], clock[k], rng, held) for k in range(len(clock))])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case")
    parser.add_argument("q1_pct", type=float)
    parser.add_argument("q2_pct", type=float)
    parser.add_argument("--seeds", default="1-9", help="noise seeds, e.g. 1-9,12")
    parser.add_argument("--own-model", action="store_true", help="the estimator's model's motion instead")
    parser.add_argument("--motion-cache", type=Path, default=None, help="keep the plant's motion here")
    parser.add_argument("--single-start", action="store_true", help="the configured start alone")
    parser.add_argument("--recentring", type=float, nargs=4, default=None, help="the model's thresholds")
    args = parser.parse_args()
    run, case = RobustnessRun(REPORT_SETTINGS), case_by_name(args.case)
    point = (args.q1_pct, args.q2_pct)
    began = time.process_time()
    true, angle, clock = plant_motion(run, case, point, args.motion_cache)
    times = DT_S * np.arange(1, len(clock) + 1)
    speed = np.array([run.speed_hz(case, t - DT_S) for t in times])
    temperature = np.array([run.temperature_c(case, t - DT_S) for t in times])
    if args.own_model:
        true = own_model_motion(run, case, point, speed, temperature)
    print(f"motion: {'own model' if args.own_model else 'plant'}, {time.process_time() - began:.0f} s CPU")
    # the estimator's thresholds: the own model's motion above stays the default model's
    if args.recentring is not None:
        speed_fraction, log_viscosity, flowrate_fraction, steps = args.recentring
        recentring = Recentring(speed_fraction, log_viscosity, flowrate_fraction, round(steps))
        reduced = build_system(run.machine, reduced=True)
        run.use_operating_model(build_operating_model(reduced, run.machine, DT_S, recentring=recentring))
    config = run.config(case)
    truth = np.array(point) / 100.0 * run.nominal_m3_s
    half = len(times) // 2
    errors = []
    for seed in [None, *seeds_of(args.seeds)]:
        began = time.process_time()
        record = measured(run, case, true, angle, clock, seed)
        trace, _ = run.estimate(case, config, record, speed, temperature, single=args.single_start)
        error = 100.0 * (trace.q_m3_s[half:].mean(axis=0) / truth - 1.0)
        std = 100.0 * trace.q_std_m3_s[-1] / truth
        if seed is not None:
            errors.append(error)
        print(
            f"{'no noise' if seed is None else f'seed {seed}':>9}: error {error[0]:+.2f} / {error[1]:+.2f} % "
            f"std {std[0]:.2f} / {std[1]:.2f} % ({time.process_time() - began:.0f} s CPU)",
            flush=True,
        )
    errors = np.array(errors)
    if len(errors) > 1:
        mean, spread = errors.mean(axis=0), errors.std(axis=0, ddof=1)
        sem, rms = spread / np.sqrt(len(errors)), np.sqrt((errors**2).mean(axis=0))
        within = np.mean(np.all(np.abs(errors) <= case.tolerance_pct, axis=1))
        print(
            f"{len(errors)} seeds: mean {mean[0]:+.2f} / {mean[1]:+.2f} % (+- {sem[0]:.2f} / {sem[1]:.2f}), "
            f"sd {spread[0]:.2f} / {spread[1]:.2f} %, rms {rms[0]:.2f} / {rms[1]:.2f} %, "
            f"both within {case.tolerance_pct:g} %: {within:.0%}"
        )


if __name__ == "__main__":
    main()
