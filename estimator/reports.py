"""What the filter reports: a :class:`StepReport` per sample and an :class:`EstimateTrace` per record.

Both are read from the filter's report array (:mod:`oilwatch.estimator.step_kernel`, ``REPORT_*`` layout),
which the compiled step fills. :meth:`oilwatch.estimator.ekf.OilFlowEKF.step` returns a :class:`ReportView`, a
StepReport whose fields are built from one copy of that array when they are read (a sample whose report nobody
reads costs one copy), and a record's trace is filled from one row per sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import channels
from .step_kernel import (
    REPORT_BASELINE_FLOWRATE,
    REPORT_BASELINE_STD,
    REPORT_CHANGING,
    REPORT_CONSISTENT,
    REPORT_CONVERGED,
    REPORT_FILTER_FLOWRATE,
    REPORT_FILTER_STD,
    REPORT_FLOWRATE,
    REPORT_MISMATCH,
    REPORT_NIS,
    REPORT_OFFSET,
    REPORT_OFFSET_STD,
    REPORT_OK,
    REPORT_ROWS,
    REPORT_STARVED,
    REPORT_STARVED_CONSISTENT,
    REPORT_STATUS,
    REPORT_STD,
    REPORT_UNBALANCE,
    REPORT_UNBALANCE_STD,
    REPORT_VISCOSITY,
    REPORT_VISCOSITY_STD,
)


@dataclass(slots=True)
class StepReport:
    """What the filter reports after one sample.

    step : index k of the sample just processed. q_m3_s, q_std_m3_s : (2,) the published estimates and their
    stds [m^3/s]: the filter's (std from P) while the model is consistent, else as ``model_mismatch`` says.
    nis : normalized innovation squared of this sample (0 when no update was made).
    n_measurements : rows used by the update (0 when no channel was usable or all were rejected).
    converged : see module docstring. measurement_ok : the update used at least one channel.
    starved : (2,) bool alarm flags. probe_status : (4,) int codes of :mod:`oilwatch.estimator.channels` (0
    healthy). model_consistent : the windowed NIS test passes. changing : (2,) bool, the change test fires on
    the bearing. starved_consistent : (2,) bool, alarm raised while the model was consistent.
    viscosity_factor, viscosity_factor_std : (2,) each bearing's estimated viscosity factor and its std
    (1 and 0 when the factors are not estimated).
    model_mismatch : the status of :mod:`oilwatch.estimator.baseline_change` (0 consistent, 1 mismatch read
    from the change relative to the baseline, 2 mismatch held). filter_q_m3_s, filter_q_std_m3_s : (2,) the
    filter's own estimates and stds. baseline_q_m3_s, baseline_q_std_m3_s : (2,) the baseline-relative static
    estimate and std (NaN when no static reference applies).
    """

    step: int
    q_m3_s: np.ndarray
    q_std_m3_s: np.ndarray
    nis: float
    n_measurements: int
    converged: bool
    measurement_ok: bool
    starved: np.ndarray
    probe_status: np.ndarray
    model_consistent: bool
    changing: np.ndarray
    starved_consistent: np.ndarray
    viscosity_factor: np.ndarray
    viscosity_factor_std: np.ndarray
    model_mismatch: int
    filter_q_m3_s: np.ndarray
    filter_q_std_m3_s: np.ndarray
    baseline_q_m3_s: np.ndarray
    baseline_q_std_m3_s: np.ndarray

    @property
    def probe_faulty(self) -> np.ndarray:
        """(4,) bool: the probe is flagged faulty and excluded."""
        return self.probe_status != channels.OK


class ReportView(StepReport):
    """A :class:`StepReport` over a copy of the filter's report array (``values``); each field is built when
    it is read (arrays: views of the copy, or new flag arrays), independent of the filter's later steps."""

    __slots__ = ("_values",)

    def __init__(self, step: int, values: np.ndarray) -> None:
        self.step = step
        self._values = values

    @property
    def values(self) -> np.ndarray:
        """The whole report (REPORT_SIZE,) in the ``REPORT_*`` layout of
        :mod:`oilwatch.estimator.step_kernel`, read only (e.g. for publishing every output from one
        ``tolist()``)."""
        view = self._values.view()
        view.flags.writeable = False
        return view

    @property
    def q_m3_s(self) -> np.ndarray:
        return self._values[REPORT_FLOWRATE : REPORT_FLOWRATE + 2]

    @property
    def q_std_m3_s(self) -> np.ndarray:
        return self._values[REPORT_STD : REPORT_STD + 2]

    @property
    def nis(self) -> float:
        return float(self._values[REPORT_NIS])

    @property
    def n_measurements(self) -> int:
        return int(self._values[REPORT_ROWS])

    @property
    def converged(self) -> bool:
        return bool(self._values[REPORT_CONVERGED])

    @property
    def measurement_ok(self) -> bool:
        return bool(self._values[REPORT_OK])

    @property
    def starved(self) -> np.ndarray:
        return self._values[REPORT_STARVED : REPORT_STARVED + 2] != 0.0

    @property
    def probe_status(self) -> np.ndarray:
        return self._values[REPORT_STATUS : REPORT_STATUS + 4].astype(np.int64)

    @property
    def model_consistent(self) -> bool:
        return bool(self._values[REPORT_CONSISTENT])

    @property
    def changing(self) -> np.ndarray:
        return self._values[REPORT_CHANGING : REPORT_CHANGING + 2] != 0.0

    @property
    def starved_consistent(self) -> np.ndarray:
        return self._values[REPORT_STARVED_CONSISTENT : REPORT_STARVED_CONSISTENT + 2] != 0.0

    @property
    def viscosity_factor(self) -> np.ndarray:
        return self._values[REPORT_VISCOSITY : REPORT_VISCOSITY + 2]

    @property
    def viscosity_factor_std(self) -> np.ndarray:
        return self._values[REPORT_VISCOSITY_STD : REPORT_VISCOSITY_STD + 2]

    @property
    def model_mismatch(self) -> int:
        return int(self._values[REPORT_MISMATCH])

    @property
    def filter_q_m3_s(self) -> np.ndarray:
        return self._values[REPORT_FILTER_FLOWRATE : REPORT_FILTER_FLOWRATE + 2]

    @property
    def filter_q_std_m3_s(self) -> np.ndarray:
        return self._values[REPORT_FILTER_STD : REPORT_FILTER_STD + 2]

    @property
    def baseline_q_m3_s(self) -> np.ndarray:
        return self._values[REPORT_BASELINE_FLOWRATE : REPORT_BASELINE_FLOWRATE + 2]

    @property
    def baseline_q_std_m3_s(self) -> np.ndarray:
        return self._values[REPORT_BASELINE_STD : REPORT_BASELINE_STD + 2]


@dataclass
class EstimateTrace:
    """Per-step outputs of :meth:`OilFlowEKF.run` and :meth:`OilFlowEKF.run_batch` for K samples: arrays
    (K, 2), (K, 4) or (K,), fields as StepReport, and each nuisance's estimate and std (the known value
    and 0 when it is not estimated)."""

    q_m3_s: np.ndarray
    q_std_m3_s: np.ndarray
    nis: np.ndarray
    n_measurements: np.ndarray
    converged: np.ndarray
    measurement_ok: np.ndarray
    starved: np.ndarray
    probe_status: np.ndarray
    model_consistent: np.ndarray
    changing: np.ndarray
    starved_consistent: np.ndarray
    offset_m: np.ndarray
    offset_std_m: np.ndarray
    viscosity_factor: np.ndarray
    viscosity_factor_std: np.ndarray
    unbalance: np.ndarray
    unbalance_std: np.ndarray
    model_mismatch: np.ndarray
    filter_q_m3_s: np.ndarray
    filter_q_std_m3_s: np.ndarray
    baseline_q_m3_s: np.ndarray
    baseline_q_std_m3_s: np.ndarray

    @property
    def probe_faulty(self) -> np.ndarray:
        """(K, 4) bool: probe flagged faulty."""
        return self.probe_status != channels.OK

    @classmethod
    def empty(cls, count: int) -> EstimateTrace:
        """A trace of ``count`` rows to be filled."""
        return cls(
            q_m3_s=np.zeros((count, 2)),
            q_std_m3_s=np.zeros((count, 2)),
            nis=np.zeros(count),
            n_measurements=np.zeros(count, dtype=np.int64),
            converged=np.zeros(count, dtype=bool),
            measurement_ok=np.zeros(count, dtype=bool),
            starved=np.zeros((count, 2), dtype=bool),
            probe_status=np.zeros((count, 4), dtype=np.int64),
            model_consistent=np.zeros(count, dtype=bool),
            changing=np.zeros((count, 2), dtype=bool),
            starved_consistent=np.zeros((count, 2), dtype=bool),
            offset_m=np.zeros((count, 4)),
            offset_std_m=np.zeros((count, 4)),
            viscosity_factor=np.ones((count, 2)),
            viscosity_factor_std=np.zeros((count, 2)),
            unbalance=np.zeros((count, 2)),
            unbalance_std=np.zeros((count, 2)),
            model_mismatch=np.zeros(count, dtype=np.int64),
            filter_q_m3_s=np.zeros((count, 2)),
            filter_q_std_m3_s=np.zeros((count, 2)),
            baseline_q_m3_s=np.zeros((count, 2)),
            baseline_q_std_m3_s=np.zeros((count, 2)),
        )

    def fill(self, table: np.ndarray, count: int) -> None:
        """Rows ``[:count]`` from the filter's report rows (:mod:`oilwatch.estimator.step_kernel` layout)."""
        rows = table[:count]
        for name, first, size in _TRACE_COLUMNS:
            target = getattr(self, name)[:count]
            values = rows[:, first] if size == 0 else rows[:, first : first + size]
            if target.dtype == bool:
                np.not_equal(values, 0.0, out=target)
            else:
                target[...] = values

    def put_rows(self, start: int, source: EstimateTrace, count: int, source_start: int = 0) -> None:
        """Rows ``start:start + count`` from ``source``'s rows ``source_start:``."""
        rows = slice(source_start, source_start + count)
        for name, _, _ in _TRACE_COLUMNS:
            getattr(self, name)[start : start + count] = getattr(source, name)[rows]


_TRACE_COLUMNS = (
    ("q_m3_s", REPORT_FLOWRATE, 2),
    ("q_std_m3_s", REPORT_STD, 2),
    ("nis", REPORT_NIS, 0),
    ("n_measurements", REPORT_ROWS, 0),
    ("converged", REPORT_CONVERGED, 0),
    ("measurement_ok", REPORT_OK, 0),
    ("starved", REPORT_STARVED, 2),
    ("probe_status", REPORT_STATUS, 4),
    ("model_consistent", REPORT_CONSISTENT, 0),
    ("changing", REPORT_CHANGING, 2),
    ("starved_consistent", REPORT_STARVED_CONSISTENT, 2),
    ("offset_m", REPORT_OFFSET, 4),
    ("offset_std_m", REPORT_OFFSET_STD, 4),
    ("viscosity_factor", REPORT_VISCOSITY, 2),
    ("viscosity_factor_std", REPORT_VISCOSITY_STD, 2),
    ("unbalance", REPORT_UNBALANCE, 2),
    ("unbalance_std", REPORT_UNBALANCE_STD, 2),
    ("model_mismatch", REPORT_MISMATCH, 0),
    ("filter_q_m3_s", REPORT_FILTER_FLOWRATE, 2),
    ("filter_q_std_m3_s", REPORT_FILTER_STD, 2),
    ("baseline_q_m3_s", REPORT_BASELINE_FLOWRATE, 2),
    ("baseline_q_std_m3_s", REPORT_BASELINE_STD, 2),
)
"""EstimateTrace field, first report column, width (0: a scalar column)."""
