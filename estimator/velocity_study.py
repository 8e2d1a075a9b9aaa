"""Which treatment of the differentiated velocities is best? A study on the toy rotor.

For each velocity-noise mode of :mod:`oilwatch.estimator.measurement`, each process-noise setting and each
constant flowrate case, the EKF runs on a record simulated by :func:`oilwatch.estimator.toy_model.simulate`
(RK4 truth, not the filter's own discrete model) and the study reports, over the last ``window_s`` of the
record:

* ``nis_ratio``: mean NIS divided by the number of channels used (1 for a consistent filter);
* ``bias_pct``: mean estimate minus truth, in % of the truth (worse of the two bearings);
* ``rms_pct``: RMS estimation error in % of the truth (worse of the two bearings);
* ``coverage``: fraction of steps where |error| < 2 std from P (0.95 for a consistent filter).

The gate is disabled so that the eight-channel modes are not silently reduced to displacement-only updates.

Process noise settings: ``"paper"`` is the paper's 10 um and 10 um/s per step; ``"consistent"`` is 0.01 um and
0.01 um x Omega per step, matched to this toy's actual model error (the truth has no process noise; the
filter's model differs from it only by interpolation and integration error).

Run ``python -m estimator.velocity_study`` to print the table.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .ekf import OilFlowEKF
from .ekf_config import RECOMMENDED_DISPLACEMENT_PROCESS_STD_M, VELOCITY_NOISE_MODES, EKFConfig
from .toy_model import NOMINAL_FLOWRATE_M3_S, SPEED_HZ, ToyRotor, simulate

_OMEGA = 2.0 * np.pi * SPEED_HZ
PROCESS_NOISE = {
    "paper": (10.0e-6, 10.0e-6),
    "recommended": (RECOMMENDED_DISPLACEMENT_PROCESS_STD_M, RECOMMENDED_DISPLACEMENT_PROCESS_STD_M * _OMEGA),
    "matched": (0.01e-6, 0.01e-6 * _OMEGA),
}
"""Dynamic process-noise stds (displacement [m], velocity [m/s]) per setting."""


def run_case(
    model: ToyRotor,
    mode: str,
    process: str,
    flowrate_fraction: tuple[float, float],
    noise_std_m: float,
    seed: int,
    duration_s: float,
    window_s: float,
) -> dict[str, float | str]:
    """One filter run on one simulated record; returns the metrics of the module docstring."""
    steps = round(duration_s / model.dt_s)
    truth = np.array(flowrate_fraction) * NOMINAL_FLOWRATE_M3_S
    record = simulate(model, np.tile(truth, (steps, 1)), noise_std_m, seed=seed)
    displacement_std, velocity_std = PROCESS_NOISE[process]
    config = EKFConfig(
        noise_std_m=noise_std_m,
        velocity_noise=mode,
        displacement_process_std_m=displacement_std,
        velocity_process_std_m_s=velocity_std,
        gate_tail_probability=0.0,
    )
    trace = OilFlowEKF(model, config).run(record.displacement_m)
    tail = slice(steps - round(window_s / model.dt_s), steps)
    error = trace.q_m3_s[tail] - truth
    channels = trace.n_measurements[tail]
    return {
        "mode": mode,
        "process": process,
        "nis_ratio": float(np.mean(trace.nis[tail][channels > 0] / channels[channels > 0])),
        "bias_pct": float(np.max(np.abs(error.mean(axis=0)) / truth) * 100.0),
        "rms_pct": float(np.max(np.sqrt((error**2).mean(axis=0)) / truth) * 100.0),
        "coverage": float(np.mean(np.abs(error) < 2.0 * trace.q_std_m3_s[tail])),
    }


def velocity_noise_study(
    noise_std_m: float = 1.0e-6,
    cases: tuple[tuple[float, float], ...] = ((0.8, 0.9), (1.0, 0.75)),
    seeds: tuple[int, ...] = (1, 2),
    processes: tuple[str, ...] = ("recommended", "matched", "paper"),
    modes: tuple[str, ...] = VELOCITY_NOISE_MODES,
    duration_s: float = 6.0,
    window_s: float = 3.0,
    progress: Callable[[int, int], None] | None = None,
) -> list[dict[str, float | str]]:
    """Average the metrics of :func:`run_case` over cases and seeds for every (process, mode) pair;
    ``progress(done, total)`` after each pair."""
    model = ToyRotor()
    rows = []
    combos = [(p, m) for p in processes for m in modes]
    for done, (process, mode) in enumerate(combos):
        runs = [
            run_case(model, mode, process, case, noise_std_m, seed, duration_s, window_s)
            for case in cases
            for seed in seeds
        ]
        row: dict[str, float | str] = {"mode": mode, "process": process}
        for key in ("nis_ratio", "bias_pct", "rms_pct", "coverage"):
            row[key] = float(np.mean([run[key] for run in runs]))
        row["max_rms_pct"] = float(np.max([run["rms_pct"] for run in runs]))
        rows.append(row)
        if progress is not None:
            progress(done + 1, len(combos))
    return rows


def format_table(rows: list[dict[str, float | str]]) -> str:
    """The study as a plain-text table."""
    lines = [
        f"{'process noise':<14}{'velocity mode':<20}{'NIS/m':>8}{'bias %':>9}{'RMS %':>8}"
        f"{'max RMS %':>11}{'2-std cover':>13}"
    ]
    for row in rows:
        lines.append(
            f"{row['process']:<14}{row['mode']:<20}{row['nis_ratio']:8.2f}{row['bias_pct']:9.3f}"
            f"{row['rms_pct']:8.3f}{row['max_rms_pct']:11.3f}{row['coverage']:13.2f}"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    for sigma in (1.0e-6, 2.0e-6):
        print(f"\nsigma_v = {sigma * 1e6:g} um")
        print(format_table(velocity_noise_study(noise_std_m=sigma)))
