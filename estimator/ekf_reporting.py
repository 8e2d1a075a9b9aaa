"""What :class:`oilwatch.estimator.ekf.OilFlowEKF` reports of its state: the public estimates and the report
array.

:class:`FilterReporting` is the part of the filter that reads its state: the SI estimates and stds of the
flowrates and the nuisances, copies of the dynamic state and of P, and the report array (``REPORT_*``
layout of :mod:`oilwatch.estimator.step_kernel`) rebuilt from the state after a reset or a restored state. The
compiled step writes that array itself after each sample.
"""

from __future__ import annotations

import numpy as np

from . import channels
from .baseline_change import CHANGE_STATUS, CONSISTENT
from .reports import ReportView, StepReport
from .step_kernel import (
    COUNT_STEP,
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


class FilterReporting:
    """The reporting half of :class:`oilwatch.estimator.ekf.OilFlowEKF` (which sets up the attributes used
    here)."""

    @property
    def flowrate_m3_s(self) -> np.ndarray:
        """(2,) current flowrate estimates [m^3/s], inside the model's table range."""
        return np.array(self._flowrate_si())

    def _flowrate_si(self) -> tuple[float, float]:
        # clipped in SI as well: the round trip through the scaled unit may leave a bound by one ulp
        n, scale = self._n, self._q_nominal
        low, high = self._bounds
        return (
            min(max(float(self._x[n]) * scale, low), high),
            min(max(float(self._x[n + 1]) * scale, low), high),
        )

    @property
    def flowrate_std_m3_s(self) -> np.ndarray:
        """(2,) standard deviations of the flowrate estimates from P [m^3/s]."""
        n = self._n
        return np.sqrt(np.diag(self._P)[n : n + 2]) * self._q_nominal

    def _nuisance(self, block: slice, known: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
        """(estimate, std) copies of a nuisance block of the state; (the known value, zeros) when the block
        is not estimated (an empty slice)."""
        if block.stop > block.start:
            return self._x[block].copy(), np.sqrt(np.diag(self._P)[block])
        return np.array(known, dtype=float), np.zeros(len(known))

    @property
    def offset_m(self) -> np.ndarray:
        """(4,) estimated probe zero offsets [m] (zeros when the offsets are not estimated)."""
        return self._nuisance(self._offsets, (0.0,) * 4)[0]

    @property
    def offset_std_m(self) -> np.ndarray:
        """(4,) their stds [m] (zeros when the offsets are not estimated)."""
        return self._nuisance(self._offsets, (0.0,) * 4)[1]

    @property
    def unbalance(self) -> np.ndarray:
        """(2,) the estimated unbalance (real, imaginary) relative to the machine file's ((1, 0) if fixed)."""
        return self._nuisance(self._unbalance, (1.0, 0.0))[0]

    @property
    def unbalance_std(self) -> np.ndarray:
        """(2,) its stds (zeros when the unbalance is not estimated)."""
        return self._nuisance(self._unbalance, (1.0, 0.0))[1]

    @property
    def viscosity_factor(self) -> np.ndarray:
        """(2,) each bearing's estimated viscosity factor (film over the oil law's; ones if not estimated)."""
        return self._nuisance(self._viscosity, (1.0, 1.0))[0]

    @property
    def viscosity_factor_std(self) -> np.ndarray:
        """(2,) their stds (zeros when the factors are not estimated)."""
        return self._nuisance(self._viscosity, (1.0, 1.0))[1]

    @property
    def dynamic_state(self) -> np.ndarray:
        """(n,) copy of the dynamic-state estimate s [SI]."""
        return self._x[: self._n].copy()

    @property
    def covariance(self) -> np.ndarray:
        """(N, N) copy of P, N = n + 2 (+ 4 with offset states); the flowrate block is in the internal unit
        (fractions of nominal)^2, the offsets' in m^2."""
        return self._P.copy()

    @property
    def step_count(self) -> int:
        """Number of samples processed."""
        return int(self._counters[COUNT_STEP])

    @property
    def settling_steps(self) -> int:
        """Samples of the settling start (:mod:`oilwatch.estimator.nuisance_start`; 0: none): the flowrates
        and nuisances restart from their prior after this sample."""
        return self._settling

    def current_report(self) -> StepReport:
        """The report of the last processed sample, rebuilt from the state (e.g. after :meth:`set_state`)."""
        self._refresh_report()
        return self._step_report(self.step_count - 1)

    def _step_report(self, step: int) -> StepReport:
        """The report of sample ``step``, on a copy of the report array (independent of the filter)."""
        return ReportView(step, self._report.copy())

    def _refresh_report(self) -> None:
        """The report array from the state as it is (after a reset or a restored state): the flowrates the
        next prediction starts from, the nuisances and the flags :meth:`current_report` reads."""
        report = self._report
        report[REPORT_FILTER_FLOWRATE : REPORT_FILTER_FLOWRATE + 2] = self._flowrate_si()
        report[REPORT_FILTER_STD : REPORT_FILTER_STD + 2] = self.flowrate_std_m3_s
        status = self._change[CHANGE_STATUS]
        report[REPORT_MISMATCH] = status
        if status == CONSISTENT:  # else the published values stay (a restored state brings them)
            report[REPORT_FLOWRATE : REPORT_FLOWRATE + 2] = self._flowrate_si()
            report[REPORT_STD : REPORT_STD + 2] = self.flowrate_std_m3_s
        report[REPORT_VISCOSITY : REPORT_VISCOSITY + 2] = self.viscosity_factor
        report[REPORT_VISCOSITY_STD : REPORT_VISCOSITY_STD + 2] = self.viscosity_factor_std
        report[REPORT_OFFSET : REPORT_OFFSET + 4] = self.offset_m
        report[REPORT_OFFSET_STD : REPORT_OFFSET_STD + 4] = self.offset_std_m
        report[REPORT_UNBALANCE : REPORT_UNBALANCE + 2] = self.unbalance
        report[REPORT_UNBALANCE_STD : REPORT_UNBALANCE_STD + 2] = self.unbalance_std
        report[REPORT_STARVED : REPORT_STARVED + 2] = self.alarm.starved
        report[REPORT_STARVED_CONSISTENT : REPORT_STARVED_CONSISTENT + 2] = self.alarm.starved_consistent
        report[REPORT_CHANGING : REPORT_CHANGING + 2] = self._changing
        report[REPORT_STATUS : REPORT_STATUS + 4] = self._health[:, channels.STATUS]

    def _set_last(self, nis: float, rows: int, ok: bool, converged: bool, consistent: bool) -> None:
        """The last sample's scalars (a reset, a restored state) and the rest of the report from the state."""
        report = self._report
        report[REPORT_NIS], report[REPORT_ROWS], report[REPORT_OK] = nis, rows, ok
        report[REPORT_CONVERGED], report[REPORT_CONSISTENT] = converged, consistent
        self._refresh_report()

    @property
    def _last(self) -> tuple[float, int, bool, bool, bool]:
        """(nis, n_measurements, measurement_ok, converged, model_consistent) of the last sample."""
        report = self._report
        return (
            float(report[REPORT_NIS]),
            int(report[REPORT_ROWS]),
            bool(report[REPORT_OK]),
            bool(report[REPORT_CONVERGED]),
            bool(report[REPORT_CONSISTENT]),
        )
