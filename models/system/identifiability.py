"""Cramer-Rao lower bounds on the supply flowrates (q1, q2) identified from the bearing displacements.

The two bounds live in their own modules and are re-exported here, the import path callers use:

- :mod:`oilwatch.models.system.orbit_bound`: the steady unbalance orbit of the linear rotor-bearing model,
only the
  flowrates (and optionally the probes' constant offsets) unknown: :func:`cramer_rao_bound`;
- :mod:`oilwatch.models.system.trajectory_bound`: along a speed / oil-temperature trajectory on the
estimator's own
  operating maps, with the viscosity factors, the unbalance and the offsets as nuisances
  (:func:`trajectory_information`, :func:`trajectory_bound_pct`) or random-walking as a filter models them
  (:func:`tracking_bound_pct`).
"""

from .orbit_bound import (
    DEFAULT_DT_S,
    DEFAULT_RELATIVE_STEP,
    M3_S_TO_ML_MIN,
    MAX_CONDITION,
    CramerRaoBound,
    OrbitModel,
    OrbitSensitivity,
    cramer_rao_bound,
    fisher_information,
    orbit_sensitivity,
    record_sensitivity,
)
from .trajectory_bound import (
    TRAJECTORY_PARAMETERS,
    OperatingSegment,
    block_response,
    map_block,
    map_response,
    map_sensitivity,
    nuisance_prior,
    parameter_columns,
    sensitivity_columns,
    sensitivity_points,
    tracking_bound_pct,
    trajectory_bound_pct,
    trajectory_information,
)

__all__ = [
    "DEFAULT_DT_S",
    "DEFAULT_RELATIVE_STEP",
    "M3_S_TO_ML_MIN",
    "MAX_CONDITION",
    "TRAJECTORY_PARAMETERS",
    "CramerRaoBound",
    "OperatingSegment",
    "OrbitModel",
    "OrbitSensitivity",
    "block_response",
    "cramer_rao_bound",
    "fisher_information",
    "map_block",
    "map_response",
    "map_sensitivity",
    "nuisance_prior",
    "orbit_sensitivity",
    "parameter_columns",
    "record_sensitivity",
    "sensitivity_columns",
    "sensitivity_points",
    "tracking_bound_pct",
    "trajectory_bound_pct",
    "trajectory_information",
]
