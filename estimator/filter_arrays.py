"""The arrays of the compiled filter step, as one struct (the transient solver's ``StepArrays`` pattern).

:class:`FilterArrays` names every array the compiled step reads or advances in place
(:func:`oilwatch.estimator.kernels.filter_step`, :func:`oilwatch.estimator.step_kernel.ekf_step`), so that its
layout is written once, here, instead of as argument lists repeated by each kernel.

The filter builds it at each reset (:meth:`oilwatch.estimator.ekf.OilFlowEKF.reset`) and hands it to the
compiled entries as ``tuple(arrays)``; they rebuild the struct inside (``FilterArrays(*packed)``, free once
compiled). A plain tuple is dispatched by numba's C fingerprint; a NamedTuple goes through Python-level
typing on every call, a sizeable share of a step (``benchmarks/ekf_step.py`` times the step).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class FilterArrays(NamedTuple):
    """The filter's arrays, N the augmented state's size, n the model's.

    state (N,), covariance (N, N) : x and P, updated in place (flowrates as fractions of nominal).
    trailing_jacobian (n, T) : the nuisance columns (viscosity factors, unbalance) of the transition's
    Jacobian. process_noise (N, N) : Q, its flowrate and unbalance entries set per step.
    augmented_jacobian, work (N, N) : scratch of the covariance prediction. stacked (8,) : scratch.
    observation4 (4, N), noise4 (4, 4) : H_a and R of the displacements; observation8 (8, N), noise8 (8, 8)
    with the differentiated velocities, or (0, N) and (0, 0) in displacement-only mode.
    settings : :func:`oilwatch.estimator.kernels.filter_step`'s. health, health_values, channel_settings : the
    probe records (:mod:`oilwatch.estimator.channels`). accepted (4,) bool, changing (2,) bool : out.
    counters (int64) : the ``COUNT_*`` of :mod:`oilwatch.estimator.step_kernel`. nis_window (C, 2), nis_sums
    (2,), history (W, 2) : the consistency and convergence ring buffers. summary_settings : the ``SUMMARY_*``.
    alarm_record, alarm_settings : :class:`oilwatch.estimator.alarm.StarvationAlarm`'s. report (REPORT_SIZE,)
    : out. change : the model-mismatch status and the baseline-relative static estimate
    (:mod:`oilwatch.estimator.baseline_change`).
    """

    state: np.ndarray
    covariance: np.ndarray
    trailing_jacobian: np.ndarray
    process_noise: np.ndarray
    augmented_jacobian: np.ndarray
    work: np.ndarray
    stacked: np.ndarray
    observation4: np.ndarray
    noise4: np.ndarray
    observation8: np.ndarray
    noise8: np.ndarray
    settings: np.ndarray
    health: np.ndarray
    health_values: np.ndarray
    channel_settings: np.ndarray
    accepted: np.ndarray
    changing: np.ndarray
    counters: np.ndarray
    nis_window: np.ndarray
    nis_sums: np.ndarray
    history: np.ndarray
    summary_settings: np.ndarray
    alarm_record: np.ndarray
    alarm_settings: np.ndarray
    report: np.ndarray
    change: np.ndarray
