"""The estimator FMU's plain step as one compiled C function, called by the loader without the GIL.

In the plain configuration (``bearing_table`` 0: the grid model at one speed, no unbalance, viscosity or
runout states, so that ``OilFlowEKF.step`` is one :func:`oilwatch.estimator.step_kernel.grid_batch` call) a
doStep of
:class:`oilwatch.fmu_src.oilwatch_ekf_slave.OilFlowEKF` is: read the inputs from the fast path's input array,
scale the positions to metres, run the compiled filter step on the filter's arrays, write the report into the
output array. :func:`plain_step` does exactly that, in the slave's order and with its arithmetic, and
:data:`plain_step_entry` is its C entry (a numba ``cfunc``): the loader (``oilwatch/cosim/native/
fmi2_loader.c``) calls it before it would take the GIL. It answers :data:`KERNEL_DONE` only for the plain
sample (a finite time stamp on the filter's grid, the next sample or one after a gap, which it predicts
through as missing samples, the speed and oil temperature still at their start values); for any other (a
skipped, repeated, off-grid or late sample, a changed operating point) it returns :data:`KERNEL_DECLINED`
having changed nothing, and the loader calls the
slave's Python step, which handles it (logging, errors). :data:`KERNEL_FAILED`: the compiled step raised
(a bug, as it would be on the Python path); the loader reports fmi2Fatal.

The arrays reach the C function as one table of addresses (:class:`PlainStepTable`, built once at the end
of initialization from arrays that live as long as the filter: its ``reset`` replaces them and runs only
in the slave's ``setup``, before the binding) and their shapes. Outputs are bit-identical to the Python
path (``tests/test_fmu_fast_path.py``): the same compiled ``grid_batch`` on the same values.
"""

from __future__ import annotations

import ctypes
import math

import numpy as np
from numba import carray, cfunc, njit, types

from oilwatch.estimator.filter_arrays import FilterArrays
from oilwatch.estimator.step_kernel import COUNT_STEP, REPORT_SIZE, grid_batch

KERNEL_DECLINED, KERNEL_DONE, KERNEL_FAILED = 0, 1, 2
""":func:`plain_step`'s answers (as ``oilwatch/cosim/native/fmi2_loader.c`` reads them)."""
# the table's first entries (then the filter's arrays in FilterArrays order)
(
    T_SHAPES,
    T_CONSTANTS,
    T_INPUTS,
    T_OUTPUTS,
    T_COLUMNS,
    T_DIVISORS,
    T_MEASUREMENT,
    T_ROW,
    T_KEYPHASOR,
    T_GRID_TRANSITION,
    T_GRID_FORCING,
    T_AXES,
    T_NEXT,
    T_JACOBIAN,
    T_FLOW_JACOBIAN,
    T_EXOGENOUS,
    T_FILTER,
) = range(17)
READ_ONLY = frozenset((T_GRID_TRANSITION, T_GRID_FORCING, T_AXES))
"""The entries :func:`plain_step` only reads: the model's grid (its transition and forcing at each node) and
its axes."""
MAX_DIMS = 4
# the constants array (float64)
C_OMEGA, C_DT, C_FIRST_TIME, C_PERIOD, C_SPEED, C_TEMPERATURE, C_TOLERANCE = range(7)
# after the shapes (int64): the integer settings
I_FIRST_STEP, I_TIME_INDEX, I_REPORTED, I_T_ESTIMATE = range(4)
INPUT_STAMP, INPUT_KEYPHASOR, INPUT_SPEED, INPUT_TEMPERATURE = 4, 5, 6, 7
"""The slave's STEP_INPUTS order: the four positions [um], then these."""
FILTER_VIEWS = (
    ("state", np.float64, 1),
    ("covariance", np.float64, 2),
    ("trailing_jacobian", np.float64, 2),
    ("process_noise", np.float64, 2),
    ("augmented_jacobian", np.float64, 2),
    ("work", np.float64, 2),
    ("stacked", np.float64, 1),
    ("observation4", np.float64, 2),
    ("noise4", np.float64, 2),
    ("observation8", np.float64, 2),
    ("noise8", np.float64, 2),
    ("settings", np.float64, 1),
    ("health", np.int64, 2),
    ("health_values", np.float64, 2),
    ("channel_settings", np.float64, 1),
    ("accepted", np.bool_, 1),
    ("changing", np.bool_, 1),
    ("counters", np.int64, 1),
    ("nis_window", np.float64, 2),
    ("nis_sums", np.float64, 1),
    ("history", np.float64, 2),
    ("summary_settings", np.float64, 1),
    ("alarm_record", np.int64, 2),
    ("alarm_settings", np.float64, 1),
    ("report", np.float64, 1),
    ("change", np.float64, 1),
)
"""The filter's arrays (:class:`oilwatch.estimator.filter_arrays.FilterArrays` order) as :func:`plain_step`
views them: name, dtype, dimensions."""
N_ENTRIES = T_FILTER + len(FILTER_VIEWS)
F_COUNTERS = T_FILTER + [name for name, _, _ in FILTER_VIEWS].index("counters")


@njit(inline="always")
def _shape(shapes, i, ndim):
    if ndim == 1:
        return (shapes[MAX_DIMS * i],)
    return (shapes[MAX_DIMS * i], shapes[MAX_DIMS * i + 1])


@njit(inline="always")
def _float(table, shapes, i, ndim):
    return carray(table[i], _shape(shapes, i, ndim), np.float64)


@njit(inline="always")
def _int(table, shapes, i, ndim):
    return carray(table[i], _shape(shapes, i, ndim), np.int64)


@njit(inline="always")
def _grid(table, shapes, i):
    s = MAX_DIMS * i
    return carray(table[i], (shapes[s], shapes[s + 1], shapes[s + 2], shapes[s + 3]), np.float64)


@njit(inline="always")
def _grid_step(table, shapes, constants, settings, measurement, packed) -> None:
    """The filter's compiled step (``OilFlowEKF.step`` on the grid model) on one sample, ``measurement``."""
    grid_batch(
        _grid(table, shapes, T_GRID_TRANSITION),
        _grid(table, shapes, T_GRID_FORCING),
        _float(table, shapes, T_AXES, 1),
        constants[C_OMEGA],
        constants[C_DT],
        shapes[settings + I_FIRST_STEP],
        measurement,
        _float(table, shapes, T_ROW, 2),
        _float(table, shapes, T_NEXT, 1),
        _float(table, shapes, T_JACOBIAN, 2),
        _float(table, shapes, T_FLOW_JACOBIAN, 2),
        _float(table, shapes, T_EXOGENOUS, 1),
        packed,
    )


@njit(cache=True)
def plain_step(table, shapes) -> int:
    """One plain doStep of the slave on the arrays of ``table`` (module docstring); KERNEL_DONE, or
    KERNEL_DECLINED with nothing changed."""
    constants = carray(table[T_CONSTANTS], (C_TOLERANCE + 1,), np.float64)
    settings = MAX_DIMS * N_ENTRIES
    inputs = _float(table, shapes, T_INPUTS, 1)
    time_index = shapes[settings + I_TIME_INDEX]
    stamp = inputs[INPUT_STAMP]
    if not np.isfinite(stamp):
        return KERNEL_DECLINED
    end = inputs[time_index] + inputs[time_index + 1]
    sample_time = end if stamp < 0.0 else stamp
    period, tolerance = constants[C_PERIOD], constants[C_TOLERANCE]
    if sample_time > end + tolerance * period:
        return KERNEL_DECLINED
    position = (sample_time - constants[C_FIRST_TIME]) / period
    index = np.floor(position + 0.5)  # round(): a tie is off the grid anyway
    f = T_FILTER
    counters = _int(table, shapes, F_COUNTERS, 1)
    if abs(position - index) > tolerance or index < counters[COUNT_STEP]:
        return KERNEL_DECLINED
    if not (
        inputs[INPUT_SPEED] == constants[C_SPEED] and inputs[INPUT_TEMPERATURE] == constants[C_TEMPERATURE]
    ):
        return KERNEL_DECLINED
    measurement = carray(table[T_MEASUREMENT], (1, 4), np.float64)
    packed = (
        _float(table, shapes, f, 1),
        _float(table, shapes, f + 1, 2),
        _float(table, shapes, f + 2, 2),
        _float(table, shapes, f + 3, 2),
        _float(table, shapes, f + 4, 2),
        _float(table, shapes, f + 5, 2),
        _float(table, shapes, f + 6, 1),
        _float(table, shapes, f + 7, 2),
        _float(table, shapes, f + 8, 2),
        _float(table, shapes, f + 9, 2),
        _float(table, shapes, f + 10, 2),
        _float(table, shapes, f + 11, 1),
        _int(table, shapes, f + 12, 2),
        _float(table, shapes, f + 13, 2),
        _float(table, shapes, f + 14, 1),
        carray(table[f + 15], _shape(shapes, f + 15, 1), np.bool_),
        carray(table[f + 16], _shape(shapes, f + 16, 1), np.bool_),
        counters,
        _float(table, shapes, f + 18, 2),
        _float(table, shapes, f + 19, 1),
        _float(table, shapes, f + 20, 2),
        _float(table, shapes, f + 21, 1),
        _int(table, shapes, f + 22, 2),
        _float(table, shapes, f + 23, 1),
        _float(table, shapes, f + 24, 1),
        _float(table, shapes, f + 25, 1),
    )
    # a gap (samples that never arrived, e.g. the start time's when the host's first input is the plant's
    # sample after one step): predicted through one missing sample at a time, as the slave's step does
    while counters[COUNT_STEP] < index:
        measurement[0, :] = np.nan
        _grid_step(table, shapes, constants, settings, measurement, packed)
    for i in range(4):
        measurement[0, i] = inputs[i] * 1e-6
    _grid_step(table, shapes, constants, settings, measurement, packed)
    report, outputs = packed[24], _float(table, shapes, T_OUTPUTS, 1)
    columns, divisors = _int(table, shapes, T_COLUMNS, 1), _float(table, shapes, T_DIVISORS, 1)
    for i in range(shapes[settings + I_REPORTED]):
        outputs[i] = report[columns[i]] / divisors[i]
    steps = counters[COUNT_STEP]
    outputs[shapes[settings + I_T_ESTIMATE]] = constants[C_FIRST_TIME] + (steps - 1) * period
    keyphasor = inputs[INPUT_KEYPHASOR]
    connected = np.isfinite(keyphasor) and keyphasor >= 0.0
    carray(table[T_KEYPHASOR], (1,), np.float64)[0] = keyphasor * (math.pi / 180.0) if connected else np.nan
    return KERNEL_DONE


@cfunc(types.intc(types.CPointer(types.voidptr)), cache=True)
def plain_step_entry(table):
    """The C entry of :func:`plain_step` (``int f(void **table)``; the shapes at ``table[T_SHAPES]``)."""
    shapes = carray(table[T_SHAPES], (1,), np.int64)
    count = shapes[0]
    try:
        return plain_step(table, carray(table[T_SHAPES], (count,), np.int64)[1:])
    except Exception:  # a bug, as it would be on the Python path: the loader reports fmi2Fatal
        return KERNEL_FAILED


class PlainStepTable:
    """The table of addresses :data:`plain_step_entry` reads (module docstring). ``arguments``: the filter's
    :meth:`oilwatch.estimator.ekf.OilFlowEKF.grid_batch_arguments`; ``slave_arrays``: the slave's input and
    output arrays, its measurement row (1, 4) and its keyphasor cell (1,). :attr:`address` is what the loader
    passes to :attr:`function` (the C entry's address). It holds every array it points to."""

    def __init__(
        self, arguments, slave_arrays, constants, columns, divisors, time_index: int, t_estimate_index: int
    ) -> None:
        transition, forcing, axes, omega, dt, first_step, *work, packed = arguments
        inputs, outputs, measurement_row, keyphasor_cell = slave_arrays
        if tuple(name for name, _, _ in FILTER_VIEWS) != FilterArrays._fields:
            raise ValueError("FilterArrays' fields differ from FILTER_VIEWS")
        self._constants = np.array([omega, dt, *constants], dtype=np.float64)
        self._columns = np.ascontiguousarray(columns, dtype=np.int64)
        self._divisors = np.ascontiguousarray(divisors, dtype=np.float64)
        self._row = np.empty((1, REPORT_SIZE))
        entries = [
            (None, None, 0),  # T_SHAPES, filled below
            (self._constants, np.float64, 1),
            (inputs, np.float64, 1),
            (outputs, np.float64, 1),
            (self._columns, np.int64, 1),
            (self._divisors, np.float64, 1),
            (measurement_row, np.float64, 2),
            (self._row, np.float64, 2),
            (keyphasor_cell, np.float64, 1),
            (transition, np.float64, 4),
            (forcing, np.float64, 4),
            (axes, np.float64, 1),
            *zip(work, (np.float64,) * 4, (1, 2, 2, 1), strict=True),
            *((array, dtype, ndim) for array, (_, dtype, ndim) in zip(packed, FILTER_VIEWS, strict=True)),
        ]
        shapes = np.zeros(1 + MAX_DIMS * N_ENTRIES + I_T_ESTIMATE + 1, dtype=np.int64)
        shapes[0] = shapes.size
        addresses = np.zeros(N_ENTRIES, dtype=np.uintp)
        for i, (array, dtype, ndim) in enumerate(entries):
            if array is None:
                continue
            if array.dtype != dtype or array.ndim != ndim or not array.flags.c_contiguous:
                raise ValueError(f"array {i} of the plain step is not {ndim}-D {np.dtype(dtype)}, C order")
            shapes[1 + MAX_DIMS * i : 1 + MAX_DIMS * i + ndim] = array.shape
            addresses[i] = array.ctypes.data
        settings = 1 + MAX_DIMS * N_ENTRIES
        shapes[settings + I_FIRST_STEP] = first_step
        shapes[settings + I_TIME_INDEX] = time_index
        shapes[settings + I_REPORTED] = self._columns.size
        shapes[settings + I_T_ESTIMATE] = t_estimate_index
        addresses[T_SHAPES] = shapes.ctypes.data
        self._shapes, self._addresses, self._arrays = shapes, addresses, entries
        self.address = addresses.ctypes.data
        self.function = plain_step_entry.address
        self._argument = addresses.ctypes.data_as(ctypes.POINTER(ctypes.c_void_p))

    def step(self) -> int:
        """:data:`plain_step_entry` on this table, as the loader calls it (tests, benchmarks)."""
        return plain_step_entry.ctypes(self._argument)

    def step_and_undo(self) -> int:
        """:meth:`step`, then every array it writes back to its values before it: the compiled step's code
        and arrays run once (the slave's warm-up in initialization) and nothing has advanced. The model's
        grid (:data:`READ_ONLY`, 6.6 MB for the bundled machine) is read only: copied and restored, it would
        flush from the caches what the step just brought in, and the first doStep would find them cold."""
        kept = [
            (array, array.copy())
            for i, (array, _, _) in enumerate(self._arrays)
            if array is not None and i not in READ_ONLY
        ]
        try:
            return self.step()
        finally:
            for array, values in kept:
                np.copyto(array, values)
