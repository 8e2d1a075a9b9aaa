"""The columns of ``oilwatch estimate``'s estimates.csv: their names from the estimator's step report and
:data:`estimator.config.NUISANCE_OUTPUTS` (SI suffixes ``_m`` and ``_m3_s`` converted to ``_um`` and
``_ml_min``), their decimals, and the nuisance columns read from the filter after each step."""

from __future__ import annotations

import dataclasses

import numpy as np

from estimator.config import ML_MIN, NUISANCE_OUTPUTS, nuisance_names, nuisance_values
from estimator.ekf import OilFlowEKF, StepReport

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
FLAG_COLUMNS = ("starved1", "starved2", "n_channels", "converged", "measurement_ok")
DECIMALS, UNITLESS_DECIMALS = 6, 9
"""estimates.csv decimals: 6 (1e-6 ml/min, 1 pm, 1 us), 9 for dimensionless nuisances (unbalance, viscosity
factors); flags and counts are integers."""


def _field_columns(name: str, value) -> tuple[list[str], float]:
    """Column names of an extra report field and the factor from its SI unit to the field unit."""
    base, scale = name, 1.0
    for suffix, unit, factor in (("_m3_s", "_ml_min", 1.0 / ML_MIN), ("_m", "_um", 1e6)):
        if name.endswith(suffix):
            base, scale = name[: -len(suffix)] + unit, factor
            break
    size = np.size(value)
    if size == 1:
        return [base], scale
    head, unit = [*base.rsplit("_", 1), ""][:2] if scale != 1.0 else (base, "")
    tail = f"_{unit}" if unit else ""
    names = [f"{head}_{label}{tail}" for label in _labels(size)]
    return names, scale


def _labels(size: int) -> list[str]:
    if size == 4:
        return ["x1", "y1", "x2", "y2"]
    if size == 2:
        return ["b1", "b2"]
    return [str(i + 1) for i in range(size)]


def estimate_columns(report: StepReport) -> tuple[list[str], list[tuple[str, float, int]]]:
    """The estimates.csv header for an estimator whose step report looks like ``report``, and the extra
    fields to copy (name, unit factor, size)."""
    columns = [
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
    ]
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


class NuisanceColumns:
    """The nuisance columns of estimates.csv (:func:`estimator.config.nuisance_names` order): the nuisances
    the filter estimates are read after every step, the known ones (zero std at the start: a zero prior)
    written as their constant values, so that a step costs only what changes."""

    def __init__(self, ekf: OilFlowEKF) -> None:
        self.ekf = ekf
        self.template = np.array(nuisance_values(ekf))
        self.varying: list[tuple[str, list[int], float]] = []  # property, its columns, unit factor
        column = 0
        for row in NUISANCE_OUTPUTS:
            count = len(row.labels)
            if np.any(np.asarray(getattr(ekf, row.std)) > 0.0):
                estimates = [column + 2 * i for i in range(count)]
                self.varying.append((row.estimate, estimates, row.scale))
                self.varying.append((row.std, [c + 1 for c in estimates], row.scale))
            column += 2 * count
        self._names = tuple(name for name, _, _ in self.varying)

    def snapshot(self) -> tuple:
        ekf = self.ekf
        return tuple(getattr(ekf, name) for name in self._names)

    def table(self, snapshots: list[tuple]) -> np.ndarray:
        out = np.tile(self.template, (len(snapshots), 1))
        for j, (_, columns, scale) in enumerate(self.varying):
            out[:, columns] = np.array([s[j] for s in snapshots], dtype=np.float64) * scale
        return out


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
