"""The columns of ``oilwatch estimate``'s estimates.csv: their names from the estimator's step report and
:data:`oilwatch.estimator.nuisance_outputs.NUISANCE_OUTPUTS` (SI suffixes ``_m`` and ``_m3_s`` converted to
``_um`` and ``_ml_min``), their decimals, and the nuisance columns read from the filter after each step."""

from __future__ import annotations

import dataclasses

import numpy as np

from oilwatch.estimator.ekf_config import ML_MIN
from oilwatch.estimator.nuisance_outputs import NUISANCE_OUTPUTS, nuisance_names
from oilwatch.estimator.reports import StepReport

BASE_FIELDS = (
    "step",
    "q_m3_s",
    "q_std_m3_s",
    "nis",
    "n_measurements",
    "converged",
    "measurement_ok",
    "starved",
)
"""StepReport fields every estimator has; any further field becomes extra columns."""
BASE_COLUMNS = (
    "time_s",
    "q1_est_ml_min",
    "q2_est_ml_min",
    "q1_std_ml_min",
    "q2_std_ml_min",
    "starved1",
    "starved2",
    "nis",
    "n_channels",
    "converged",
    "measurement_ok",
    "x1_um",
    "y1_um",
    "x2_um",
    "y2_um",
    "speed_hz",
    "oil_temperature_c",
)
"""The first columns of every estimates.csv (the extra fields and the nuisances follow)."""
FLAG_COLUMNS = ("starved1", "starved2", "n_channels", "converged", "measurement_ok")
DECIMALS, UNITLESS_DECIMALS = 6, 9
"""estimates.csv decimals: 6 (1e-6 ml/min, 1 pm, 1 us), 9 for dimensionless nuisances (unbalance, viscosity
factors); flags and counts are integers."""


def _field_columns(name: str, value) -> tuple[list[str], float]:
    """Column names of an extra report field and the factor from its SI unit to the field unit."""
    head, tail, scale = name, "", 1.0
    for suffix, unit, factor in (("_m3_s", "_ml_min", 1.0 / ML_MIN), ("_m", "_um", 1e6)):
        if name.endswith(suffix):
            head, tail, scale = name[: -len(suffix)], unit, factor
            break
    size = np.size(value)
    if size == 1:
        return [head + tail], scale
    return [f"{head}_{label}{tail}" for label in _labels(size)], scale


def _labels(size: int) -> list[str]:
    if size == 4:
        return ["x1", "y1", "x2", "y2"]
    if size == 2:
        return ["b1", "b2"]
    return [str(i + 1) for i in range(size)]


def estimate_columns(report: StepReport) -> tuple[list[str], list[tuple[str, float, int]]]:
    """The estimates.csv header for an estimator whose step report looks like ``report``, and the extra
    fields to copy (name, unit factor, size)."""
    columns = list(BASE_COLUMNS)
    extras = []
    covered = {name for row in NUISANCE_OUTPUTS for name in (row.estimate, row.std)}
    for item in dataclasses.fields(report):
        if item.name in BASE_FIELDS or item.name in covered:  # nuisances: the columns of nuisance_names()
            continue
        value = getattr(report, item.name)
        names, scale = _field_columns(item.name, value)
        columns += names
        extras.append((item.name, scale, len(names)))
    columns += [row[0] for row in nuisance_names()]
    return columns, extras


class TraceRows:
    """estimates.csv rows of a block from the estimator's per-sample arrays (an
    :class:`oilwatch.estimator.ekf.EstimateTrace`: fields named as the step report's and the nuisance
    properties
    :data:`oilwatch.estimator.nuisance_outputs.NUISANCE_OUTPUTS`), column block by column block: a few numpy
    copies per block, nothing per sample."""

    def __init__(self, columns: list[str], extras: list[tuple[str, float, int]]) -> None:
        self.width = len(columns)
        plan: list[tuple[slice, str, float]] = []  # columns, trace field, unit factor
        column = len(BASE_COLUMNS)
        for name, factor, size in extras:
            plan.append((slice(column, column + size), name, factor))
            column += size
        for row in NUISANCE_OUTPUTS:
            count = len(row.labels)
            plan.append((slice(column, column + 2 * count, 2), row.estimate, row.scale))
            plan.append((slice(column + 1, column + 2 * count, 2), row.std, row.scale))
            column += 2 * count
        if column != self.width:
            raise ValueError(f"internal: {column} trace columns for a header of {self.width}")
        self._plan = plan

    def rows(self, block, trace, count: int) -> np.ndarray:
        """(count, width) rows of ``block``'s samples from the first ``count`` rows of ``trace``."""
        rows = np.empty((count, self.width))
        scale = 1.0 / ML_MIN
        rows[:, 0] = block.time_s
        np.multiply(trace.q_m3_s[:count], scale, out=rows[:, 1:3])
        np.multiply(trace.q_std_m3_s[:count], scale, out=rows[:, 3:5])
        rows[:, 5:7] = trace.starved[:count]
        rows[:, 7] = trace.nis[:count]
        rows[:, 8] = trace.n_measurements[:count]
        rows[:, 9] = trace.converged[:count]
        rows[:, 10] = trace.measurement_ok[:count]
        np.multiply(block.position_m, 1e6, out=rows[:, 11:15])
        rows[:, 15] = block.speed_hz
        rows[:, 16] = block.oil_temperature_c
        for columns, name, factor in self._plan:
            values = getattr(trace, name)[:count].reshape(count, -1)
            if factor == 1.0:
                rows[:, columns] = values
            else:
                np.multiply(values, factor, out=rows[:, columns])
        return rows


def column_decimals(columns: list[str], report: StepReport) -> np.ndarray:
    """Decimals of each estimates.csv column (:data:`DECIMALS`): 0 for flags, counts and status codes."""
    integers = set(FLAG_COLUMNS)
    for item in dataclasses.fields(report):
        value = np.asarray(getattr(report, item.name))
        if value.dtype.kind in "biu" and item.name not in BASE_FIELDS:
            integers.update(_field_columns(item.name, value)[0])
    unitless = {name for name, unit, _, _ in nuisance_names() if unit == "1"}
    return np.array(
        [0 if n in integers else UNITLESS_DECIMALS if n in unitless else DECIMALS for n in columns]
    )
