"""The estimator's configuration as a user sets it: field units, ranges and descriptions.

:data:`ESTIMATOR_PARAMETERS` is generated from :class:`oilwatch.estimator.ekf_config.EKFConfig` (defaults: its
recommended tuning; the nuisances' priors: :data:`PRESET_VALUE`, the chosen preset's) and the alarm's field
metadata; the estimator FMU's parameter table and the CLI's
``--set ekf.NAME`` help are generated from it, never retyped.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from oilwatch.models.validation import MAX_PROBE_UM

from .alarm_config import AlarmConfig
from .ekf_config import DEFAULT_PRESET, ML_MIN, PRESETS, EKFConfig, preset_named


@dataclass(frozen=True)
class BoundaryParameter:
    """One configuration field as a user sets it (an FMU parameter, a CLI ``--set``): in the field's units.

    name: the user's name (``q_std_displacement_um``); field: the :class:`EKFConfig` field (``alarm.x`` for an
    :class:`AlarmConfig` one); scale: SI value = scale x user value; default: the recommended configuration's
    value in the user's unit; low, high: allowed range (None: unbounded).
    """

    name: str
    field: str
    unit: str
    scale: float
    default: float
    low: float | None
    high: float | None
    description: str

    def si(self, value: float) -> float:
        """The SI value of a user value."""
        return value * self.scale


# ---------------------------------------------------------------- nuisance states at the user's boundary
# One row per nuisance: its prior (parameters: name, EKFConfig field, unit, SI per user unit, min, max,
# description) and its estimate (outputs, see estimator.nuisance_outputs). The estimator FMU and
# `oilwatch estimate` generate their variables and columns from these rows; a new nuisance is one row in each.
# The probes' mounting angle is a machine fact both FMUs share: fmu_src/machine_parameters.py declares it.
PRESET_VALUE = -1.0
"""Value of a nuisance prior standing for the chosen preset's (:data:`oilwatch.estimator.ekf_config.PRESETS`);
for ``offset_prior_std_um`` a preset that estimates the offsets takes the machine file's ``[probes]
offset_prior_std_um``."""
OFFSET_PRIOR_FROM_MACHINE = PRESET_VALUE


def _preset_values(field: str, scale: float) -> str:
    """'machine: 2; paper: 0': each preset's value of a field in the user's unit (the offsets: the machine
    file's [probes] prior or 0)."""
    parts = []
    for preset in PRESETS:
        if field == "offset_prior_std_m":
            text = "the machine file's [probes] offset_prior_std_um" if preset.offsets_from_machine else "0"
        else:
            text = f"{preset.value(field, getattr(EKFConfig.recommended(), field)) / scale:g}"
        parts.append(f"{preset.name}: {text}")
    return "; ".join(parts)


NUISANCE_PRIORS = (
    ("offset_prior_std_um", "offset_prior_std_m", "um", 1e-6, PRESET_VALUE, 1000.0,
     "Prior std of each probe's zero offset; 0: the offsets are known to be zero (the paper's calibrated "
     "probes); > 0 estimates four offset states drifting as the machine file's [probes] "
     "offset_random_walk_um_sqrt_s; -1: the preset's (" + _preset_values("offset_prior_std_m", 1e-6)
     + "). A baseline_file sets the offsets' prior instead"),
    ("unbalance_prior_std", "unbalance_prior_std", "1", 1.0, PRESET_VALUE, 10.0,
     "Prior std of each part of the unbalance relative to the machine file's (estimate starts at 1 + 0i); "
     "0: the machine file's unbalance is exact; > 0 estimates it as a complex random walk; -1: the preset's ("
     + _preset_values("unbalance_prior_std", 1.0) + ")"),
    ("viscosity_factor_prior_std", "viscosity_factor_prior_std", "1", 1.0, PRESET_VALUE, 0.5,
     "Prior std of each bearing's viscosity factor (film over the oil law at the measured temperature); "
     "0: known (1); > 0 estimates both (needs bearing_table = 1); -1: the preset's ("
     + _preset_values("viscosity_factor_prior_std", 1.0) + ")"),
)  # fmt: skip
PRESET_PARAMETERS = tuple(row[0] for row in NUISANCE_PRIORS)
"""The parameters whose default (:data:`PRESET_VALUE`) is the chosen preset's."""


def _estimator_parameters() -> tuple[BoundaryParameter, ...]:
    recommended = EKFConfig.recommended()
    own = (
        ("noise_um", "noise_std_m", "um", 1e-6, 1e-3, MAX_PROBE_UM,
         "Std of the white measurement noise of each probe (R = noise^2)"),
        ("q_std_displacement_um", "displacement_process_std_m", "um", 1e-6, 0.0, MAX_PROBE_UM,
         "Process-noise std per step of every displacement state. Default: the recommended tuning; the "
         "paper's 10 um makes the filter inconsistent (NIS/m 0.14), more biased and slower to alarm"),
        ("q_std_flow_ml_min", "flowrate_process_std_m3_s", "ml/min", ML_MIN, 0.0, 1000.0,
         "Process-noise std per step of each flowrate state (paper and recommended: 0.1 ml/min)"),
        ("gate_tail_probability", "gate_tail_probability", "1", 1.0, 0.0, 0.5,
         "Innovation gate, per probe: a channel whose squared standardized innovation exceeds the "
         "chi-square(1) quantile 1 - p times its recent innovation power is rejected (never forced through); "
         "0 disables it"),
    )  # fmt: skip
    table = [
        BoundaryParameter(name, key, unit, scale, getattr(recommended, key) / scale, low, high, text)
        for name, key, unit, scale, low, high, text in own
    ]
    table += [
        BoundaryParameter(name, key, unit, scale, PRESET_VALUE, low, high, text)
        for name, key, unit, scale, low, high, text in NUISANCE_PRIORS
    ]
    for spec in fields(AlarmConfig):
        meta = spec.metadata
        table.append(
            BoundaryParameter(
                f"alarm_{spec.name}", f"alarm.{spec.name}", meta["unit"], 1.0, spec.default,
                meta["low"], meta["high"], meta["description"],
            )
        )  # fmt: skip
    return tuple(table)


ESTIMATOR_PARAMETERS: tuple[BoundaryParameter, ...] = _estimator_parameters()
"""The estimator's user-settable configuration (FMU parameters of OilFlowEKF, ``--set ekf.NAME``)."""


def preset_parameter(name: str, preset: str, machine_offset_prior_std_m: float) -> float:
    """The user value of a :data:`PRESET_PARAMETERS` parameter left at :data:`PRESET_VALUE` under ``preset``
    (the offsets' from ``machine_offset_prior_std_m`` [m] when the preset estimates them)."""
    chosen = preset_named(preset)
    if name == "offset_prior_std_um":
        return machine_offset_prior_std_m * 1e6 if chosen.offsets_from_machine else 0.0
    row = next(row for row in NUISANCE_PRIORS if row[0] == name)
    return chosen.value(row[1], getattr(EKFConfig.recommended(), row[1])) / row[3]


def config_from_parameters(
    values: dict[str, float],
    preset: str = DEFAULT_PRESET,
    machine_offset_prior_std_m: float = 0.0,
    **fixed,
) -> EKFConfig:
    """An :class:`EKFConfig` (the preset ``preset`` over the recommended tuning) from user values of
    :data:`ESTIMATOR_PARAMETERS` by name (missing ones keep their default; :data:`PRESET_VALUE` ones the
    preset's, the offsets' from ``machine_offset_prior_std_m``) and further SI fields ``fixed``."""
    direct, alarm = {}, {}
    for parameter in ESTIMATOR_PARAMETERS:
        user = values.get(parameter.name, parameter.default)
        if parameter.name in PRESET_PARAMETERS and user == PRESET_VALUE:
            user = preset_parameter(parameter.name, preset, machine_offset_prior_std_m)
        value = parameter.si(user)
        if parameter.field.startswith("alarm."):
            alarm[parameter.field.removeprefix("alarm.")] = value
        else:
            direct[parameter.field] = value
    return EKFConfig.preset(preset, **direct, alarm=AlarmConfig(**alarm), **fixed)


def config_field_names() -> tuple[str, ...]:
    """Names of the :class:`EKFConfig` fields (for wrappers such as the FMU that map their parameters)."""
    return tuple(f.name for f in fields(EKFConfig))
