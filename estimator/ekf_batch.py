"""Records through :class:`oilwatch.estimator.ekf.OilFlowEKF`: :meth:`BatchRuns.run` and
:meth:`BatchRuns.run_batch`.

Both give exactly what as many :meth:`oilwatch.estimator.ekf.OilFlowEKF.step` calls give
(tests/test_ekf_run_batch.py, bit for bit). On a grid model at one speed with no operating point given a whole
block is one compiled call (:func:`oilwatch.estimator.step_kernel.grid_batch`: the grid's transition and the
filter's step per sample); otherwise each sample goes through the filter's ``_advance``, its report stored as
a row of a table.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from oilwatch.models.validation import InputError

from .reports import EstimateTrace
from .step_kernel import REPORT_SIZE, grid_batch


class BatchRuns:
    """The record half of :class:`oilwatch.estimator.ekf.OilFlowEKF` (which sets up the attributes used
    here)."""

    def run(
        self,
        displacements_m: np.ndarray,
        progress: Callable[[int, int], None] | None = None,
        speed_hz: np.ndarray | None = None,
        oil_temperature_c: np.ndarray | None = None,
    ) -> EstimateTrace:
        """Process a record of K samples (K, 4) [m] as K :meth:`step` calls; return the per-step outputs.

        ``speed_hz`` and ``oil_temperature_c`` (K,), when given, are each sample's measured operating point
        (see :meth:`step`). ``progress(done, total)`` is called every 100 samples and at the end."""
        record, operating = self._batch_inputs(displacements_m, speed_hz, oil_temperature_c)
        count = record.shape[0]
        trace = EstimateTrace.empty(count)
        table = np.empty((count, REPORT_SIZE))
        for start in range(0, count, 100):
            if progress is not None:
                progress(start, count)
            stop = min(start + 100, count)
            self._advance_rows(record, operating, start, stop, table)
        if progress is not None:
            progress(count, count)
        trace.fill(table, count)
        return trace

    def run_batch(
        self,
        displacements_m: np.ndarray,
        speed_hz: np.ndarray | None = None,
        oil_temperature_c: np.ndarray | None = None,
        out: EstimateTrace | None = None,
    ) -> EstimateTrace:
        """K samples (K, 4) [m] on from the filter's current state, bit-identical to K :meth:`step` calls,
        without a StepReport per sample: the batch entry of ``oilwatch estimate``.

        ``speed_hz`` [Hz] and ``oil_temperature_c`` [degC] (K,) as in :meth:`step`; a NaN entry means not
        given for that sample (the model keeps the last value). ``out``: a trace of at least K rows whose
        first K rows are filled and which is returned (no allocation per block); else a new trace."""
        record, operating = self._batch_inputs(displacements_m, speed_hz, oil_temperature_c, missing=True)
        count = record.shape[0]
        if out is None:
            out = EstimateTrace.empty(count)
        elif out.q_m3_s.shape[0] < count:
            raise InputError(f"out must have at least {count} rows, got {out.q_m3_s.shape[0]}")
        table = self._batch_table
        if table.shape[0] < count:
            table = self._batch_table = np.empty((count, REPORT_SIZE))
        self._advance_rows(record, operating, 0, count, table)
        out.fill(table, count)
        return out

    def grid_batch_arguments(self) -> tuple | None:
        """The arguments of :func:`oilwatch.estimator.step_kernel.grid_batch` that belong to this filter, in
        its order less the record and the report table: ``(transition, forcing, axes, omega, dt, first_step,
        next, transition_work, flow_jacobian, exogenous, packed)``; None unless the filter steps as one
        compiled call (a grid model at one speed). The arrays are the filter's own storage: a compiled
        caller that runs ``grid_batch`` on them (the estimator FMU's plain step,
        :mod:`oilwatch.fmu_src.ekf_plain_step`) advances the filter exactly as :meth:`step` does. They stay
        valid through :meth:`set_state` (which copies into them) and are replaced by ``reset``."""
        if self._grid_batch is None:
            return None
        return (
            *self._grid_batch,
            self._first_step,
            self._batch_next,
            self._batch_transition,
            self._batch_flow_jacobian,
            self._batch_exogenous,
            self._packed,
        )

    def _run_grid_batch(self, record: np.ndarray, table: np.ndarray) -> None:
        """:func:`oilwatch.estimator.step_kernel.grid_batch` on the record's rows (K, 4), reports into
        ``table``."""
        transition, forcing, axes, omega, dt = self._grid_batch
        grid_batch(
            transition,
            forcing,
            axes,
            omega,
            dt,
            self._first_step,
            record,
            table,
            self._batch_next,
            self._batch_transition,
            self._batch_flow_jacobian,
            self._batch_exogenous,
            self._packed,
        )

    def _batch_inputs(self, displacements_m, speed_hz, oil_temperature_c, missing: bool = False):
        """The record (K, 4) and the per-sample operating point as lists of Python floats or None (or None
        for a column not given); ``missing``: NaN entries are None."""
        record = np.asarray(displacements_m, dtype=np.float64)
        if record.ndim != 2 or record.shape[1] != 4:
            raise InputError(f"displacements_m must have shape (K, 4), got {record.shape}")
        count = record.shape[0]
        operating = []
        for name, values in (("speed_hz", speed_hz), ("oil_temperature_c", oil_temperature_c)):
            if values is not None:
                values = np.asarray(values, dtype=float)
                if values.shape != (count,):
                    raise InputError(f"{name} must have shape ({count},), got {values.shape}")
                values = values.tolist()
                if missing:
                    values = [None if v != v else v for v in values]
            operating.append(values)
        return record, operating

    def _advance_rows(self, record, operating, start: int, stop: int, table: np.ndarray) -> None:
        """Samples ``start:stop`` of the record through :meth:`_advance`, each report into ``table``'s row
        (all in one compiled call for a grid model at one speed with no operating point given)."""
        advance, report = self._advance, self._report
        speed, temperature = operating
        if speed is None and temperature is None and self._grid_batch is not None:
            self._run_grid_batch(np.ascontiguousarray(record[start:stop]), table[start:stop])
            return
        if speed is None and temperature is None:
            for k in range(start, stop):
                advance(record[k], None, None, None)
                table[k] = report
            return
        for k in range(start, stop):
            advance(
                record[k],
                None if speed is None else speed[k],
                None if temperature is None else temperature[k],
                None,
            )
            table[k] = report
