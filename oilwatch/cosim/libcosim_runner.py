"""Run an .ssp in libcosim (the Open Simulation Platform's engine, through libcosimpy 0.0.6).

A second, independent FMI importer for the same system: it reads the SSP's components, inline
parameter bindings and connections itself. Its fixed-step algorithm is Jacobi-like: every slave
steps on the inputs it had at the start of the step, so each connection lags one macro step
behind the oilwatch master's Gauss-Seidel order.

libcosimpy notes (0.0.6): times are integer nanoseconds; ``CosimExecution.from_ssp_file`` takes
the ``.ssp`` archive (or an .ssd / folder) and fails with ``AssertionError``; the last-value
observer must be added before the first step; the first ``step()`` also initializes the slaves,
so no value exists for the start time.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import SlaveError, SystemDescriptionError
from .ssp import open_ssp

NANOSECONDS = 1_000_000_000


def run_ssp_libcosim(
    ssp_path: str | Path,
    record: list[str],
    stop_time: float | None = None,
    step_size: float | None = None,
) -> dict[str, np.ndarray]:
    """Simulate the .ssp with libcosim; return ``{"time": (n,), "instance.variable": (n,)}``.

    Rows are the values after each macro step (t = start + h, ..., stop). ``stop_time`` and
    ``step_size`` [s] default to the SSP's default experiment.
    """
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    with open_ssp(ssp_path) as system:
        start = system.start_time
        stop = system.stop_time if stop_time is None else stop_time
        step = system.step_size if step_size is None else step_size
    if stop is None or step is None or not step > 0 or not stop > start:
        raise SystemDescriptionError(
            f"need step_size > 0 and stop_time > start_time, got {step}, {start}, {stop}"
        )
    step_ns = round(step * NANOSECONDS)
    steps = round((stop - start) / step)
    log_output_level(CosimLogLevel.ERROR)
    try:
        execution = CosimExecution.from_ssp_file(str(ssp_path), step_size=step_ns)
    except AssertionError as error:
        raise SystemDescriptionError(f"libcosim cannot load {ssp_path}: {error}") from None
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)

    readers = []
    for position, column in enumerate(record):
        instance, _, name = column.partition(".")
        index = execution.slave_index_from_instance_name(instance)
        if index is None:
            raise SystemDescriptionError(f"recorded variable {column!r}: no instance {instance!r}")
        variables = {v.name.decode(): v for v in execution.slave_variables(index)}
        if name not in variables:
            raise SystemDescriptionError(f"recorded variable {column!r}: no such variable")
        kind = CosimVariableType(variables[name].type).name
        getter = {
            "REAL": observer.last_real_values,
            "INTEGER": observer.last_integer_values,
            "BOOLEAN": observer.last_boolean_values,
        }.get(kind)
        if getter is None:
            raise SystemDescriptionError(f"recorded variable {column!r} has type {kind}")
        readers.append((position, getter, index, variables[name].reference))

    table = np.empty((steps, len(record) + 1))
    for k in range(steps):
        if not execution.step():
            from libcosimpy._internal import get_last_error_message

            raise SlaveError(
                "libcosim",
                "cosim_execution_step",
                start + k * step,
                "error",
                [get_last_error_message()],
            )
        table[k, 0] = start + (k + 1) * step
        for position, getter, index, reference in readers:
            table[k, position + 1] = getter(index, [reference])[0]
    return {name: table[:, i] for i, name in enumerate(["time", *record])}
