"""The clock of the EKF step benchmarks' library rows and their time per step.

Wall time by default; ``benchmarks/ekf_step.py --cpu`` switches every row to the process's CPU time (a
shared machine) through :func:`use_process_time`, read at call time by the other modules' rows.
"""

from __future__ import annotations

import time

import numpy as np

_CLOCK = time.perf_counter


def use_process_time() -> None:
    """Time the library rows in the process's CPU time from now on."""
    global _CLOCK
    _CLOCK = time.process_time


def clock() -> float:
    """The rows' clock now [s]: wall time, or the process's CPU time after :func:`use_process_time`."""
    return _CLOCK()


def time_per_step(make_filter, record: np.ndarray, repeats: int) -> tuple[float, float]:
    """Median and minimum over ``repeats`` of the mean time per step [us] of a fresh filter
    (:func:`clock`)."""
    samples = []
    for _ in range(repeats):
        step = make_filter().step
        start = clock()
        for z in record:
            step(z)
        samples.append((clock() - start) / len(record) * 1e6)
    return float(np.median(samples)), float(np.min(samples))
