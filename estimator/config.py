"""Configuration of the oil-flow EKF and of the starvation alarm: the one import path for all of it.

The parts live one concept per module and are re-exported here, where callers, the estimator FMU and the
README import them from:

- :mod:`oilwatch.estimator.ekf_config`: :class:`EKFConfig` (validated on construction, SI, the paper's
defaults) and
  the recommended tuning's constants;
- :mod:`oilwatch.estimator.alarm_config`: :class:`AlarmConfig`, the starvation alarm's thresholds;
- :mod:`oilwatch.estimator.offset_baseline`: :class:`OffsetBaseline`, the prior a commissioning baseline
gives;
- :mod:`oilwatch.estimator.boundary_parameters`: :data:`ESTIMATOR_PARAMETERS`, this configuration as a user
sets it
  (field units, ranges, descriptions): the estimator FMU's variable table and the CLI's help are generated
  from it, never retyped;
- :mod:`oilwatch.estimator.nuisance_outputs`: :data:`NUISANCE_OUTPUTS`, the estimated nuisances as outputs.
"""

from .alarm_config import AlarmConfig
from .boundary_parameters import (
    ESTIMATOR_PARAMETERS,
    NUISANCE_PRIORS,
    OFFSET_PRIOR_FROM_MACHINE,
    PRESET_PARAMETERS,
    PRESET_VALUE,
    BoundaryParameter,
    config_field_names,
    config_from_parameters,
)
from .ekf_config import (
    DEFAULT_PRESET,
    INITIAL_FLOWRATE_STD_FRACTION,
    INITIAL_STATE_MODES,
    ML_MIN,
    PRESET_NAMES,
    PRESETS,
    RECOMMENDED_DISPLACEMENT_PROCESS_STD_M,
    VELOCITY_NOISE_MODES,
    EKFConfig,
    Preset,
    preset_named,
)
from .nuisance_outputs import (
    NUISANCE_OUTPUTS,
    NuisanceOutput,
    nuisance_names,
    nuisance_snapshot,
    nuisance_table,
    nuisance_values,
)
from .offset_baseline import OffsetBaseline

__all__ = [
    "DEFAULT_PRESET",
    "ESTIMATOR_PARAMETERS",
    "INITIAL_FLOWRATE_STD_FRACTION",
    "INITIAL_STATE_MODES",
    "ML_MIN",
    "NUISANCE_OUTPUTS",
    "NUISANCE_PRIORS",
    "OFFSET_PRIOR_FROM_MACHINE",
    "PRESETS",
    "PRESET_NAMES",
    "PRESET_PARAMETERS",
    "PRESET_VALUE",
    "RECOMMENDED_DISPLACEMENT_PROCESS_STD_M",
    "VELOCITY_NOISE_MODES",
    "AlarmConfig",
    "BoundaryParameter",
    "EKFConfig",
    "NuisanceOutput",
    "OffsetBaseline",
    "Preset",
    "config_field_names",
    "config_from_parameters",
    "nuisance_names",
    "nuisance_snapshot",
    "nuisance_table",
    "nuisance_values",
    "preset_named",
]
