"""The estimated nuisance states at the user's boundary: FMU outputs and ``oilwatch estimate`` columns.

One :class:`NuisanceOutput` row per nuisance (its estimate and std per component, in user units); the
estimator FMU and ``oilwatch estimate`` generate their variables and columns from these rows, so a new
nuisance is one row here and one prior row in :data:`oilwatch.estimator.boundary_parameters.NUISANCE_PRIORS`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class NuisanceOutput:
    """One estimated nuisance as outputs: per label, the estimate ``<stem>_<label>[_<unit>]`` and its std
    ``<stem>_<label>_std[_<unit>]`` (no unit suffix for unit "1").

    estimate, std : names of the :class:`oilwatch.estimator.ekf.OilFlowEKF` properties giving the (n,) SI
    values; scale : user value = scale x SI value; description : with ``{label}`` for the component; known :
    the estimates' values (user unit) while the nuisance is known (not estimated; None: zeros).
    """

    stem: str
    labels: tuple[str, ...]
    unit: str
    scale: float
    estimate: str
    std: str
    description: str
    known: tuple[float, ...] | None = None

    def names(self, label: str) -> tuple[str, str]:
        """(estimate name, std name) of one component."""
        suffix = "" if self.unit == "1" else f"_{self.unit}"
        return f"{self.stem}_{label}{suffix}", f"{self.stem}_{label}_std{suffix}"


NUISANCE_OUTPUTS = (
    NuisanceOutput("offset", ("x1", "y1", "x2", "y2"), "um", 1e6, "offset_m", "offset_std_m",
                   "Estimated zero offset of probe {label} along its axis (0 while the offsets are known)"),
    NuisanceOutput("unbalance", ("re", "im"), "1", 1.0, "unbalance", "unbalance_std",
                   "Estimated unbalance relative to the machine file's, {label} part (re: real, im: "
                   "imaginary; 1 and 0 while it is known)", (1.0, 0.0)),
    NuisanceOutput("viscosity_factor", ("b1", "b2"), "1", 1.0, "viscosity_factor", "viscosity_factor_std",
                   "Estimated effective viscosity factor of bearing {label} (film viscosity over the oil "
                   "law's at the measured temperature; 1 while known: viscosity_factor_prior_std 0)",
                   (1.0, 1.0)),
)  # fmt: skip


def nuisance_values(ekf) -> list[float]:
    """The current nuisance estimates and stds of a filter in user units, in :func:`nuisance_names` order."""
    values = []
    for row in NUISANCE_OUTPUTS:
        estimate, std = getattr(ekf, row.estimate), getattr(ekf, row.std)
        for i in range(len(row.labels)):
            values += (float(estimate[i]) * row.scale, float(std[i]) * row.scale)
    return values


def nuisance_snapshot(ekf) -> tuple:
    """The SI arrays behind the nuisance outputs of a filter now: (estimate, std) of each row, for
    :func:`nuisance_table` (cheap per sample: no conversion)."""
    return tuple(getattr(ekf, name) for row in NUISANCE_OUTPUTS for name in (row.estimate, row.std))


def nuisance_table(snapshots: list) -> np.ndarray:
    """(n, m) user-unit values of n :func:`nuisance_snapshot` results, in :func:`nuisance_names` order (the
    rows of :func:`nuisance_values`)."""
    columns = []
    for j, row in enumerate(NUISANCE_OUTPUTS):
        estimate = np.array([s[2 * j] for s in snapshots], dtype=np.float64).reshape(len(snapshots), -1)
        std = np.array([s[2 * j + 1] for s in snapshots], dtype=np.float64).reshape(len(snapshots), -1)
        for i in range(len(row.labels)):
            columns += [estimate[:, i] * row.scale, std[:, i] * row.scale]
    return np.column_stack(columns)


def nuisance_names() -> list[tuple[str, str, str, float]]:
    """(name, unit, description, value while known) of every nuisance output, estimates and stds
    interleaved."""
    out = []
    for row in NUISANCE_OUTPUTS:
        known = row.known or (0.0,) * len(row.labels)
        for label, start in zip(row.labels, known, strict=True):
            text = row.description.format(label=label)
            estimate, std = row.names(label)
            out += [
                (estimate, row.unit, text, start),
                (std, row.unit, f"Std of {estimate} (from the covariance P)", 0.0),
            ]
    return out
