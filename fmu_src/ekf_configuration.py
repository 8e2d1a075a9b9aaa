"""The estimator FMU's estimator from its parameters: their checks, the model, the configuration (field units
-> SI) and the commissioning baseline.

The estimator itself is :func:`oilwatch.estimator.factory.make_estimator`'s for that model and configuration
(one filter, or the start bank where it applies), as ``oilwatch estimate`` and the robustness report build it.
"""

from __future__ import annotations

import math
from pathlib import Path

from oilwatch.estimator.baseline import load_baseline, load_clearance_factors, load_runout
from oilwatch.estimator.boundary_parameters import (
    ESTIMATOR_PARAMETERS,
    PRESET_PARAMETERS,
    PRESET_VALUE,
    config_from_parameters,
)
from oilwatch.estimator.ekf_config import (
    INITIAL_FLOWRATE_STD_FRACTION,
    ML_MIN,
    RECOMMENDED_DISPLACEMENT_PROCESS_STD_M,
    EKFConfig,
    preset_named,
)
from oilwatch.estimator.runout import runout_of_probes
from oilwatch.fmu_src.ekf_variables import GRID_TOLERANCE, PRESET_TABLE
from oilwatch.fmu_src.grid_store import grid_key, load_grid, store_grid
from oilwatch.fmu_src.machine_parameters import probe_angle_deg
from oilwatch.models.probes import read_probes
from oilwatch.models.system.augmented import GridAugmentedModel
from oilwatch.models.system.operating_model import build_operating_model
from oilwatch.models.validation import InputError

SECONDS_PER_DAY = 86400.0
VELOCITY_MODES = ("displacement-only", "paper")
"""The estimator's velocity_noise of each ``velocity_channels`` value."""


def check_parameters(slave) -> None:
    """Check the parameters beyond their declared ranges (``InputError`` naming the parameter) and resolve
    ``bearing_table`` -1 to the ``preset``'s."""
    preset = preset_named(slave.preset)
    if slave.bearing_table == PRESET_TABLE:
        slave.bearing_table = int(preset.follow_operating_point)
    for name in PRESET_PARAMETERS:
        value = getattr(slave, name)
        if value < 0.0 and value != PRESET_VALUE:
            raise InputError(f"{name} must be >= 0 or {PRESET_VALUE:g} (the preset's), got {value:g}")
    if slave.q_std_velocity_um_s < 0.0 and slave.q_std_velocity_um_s != -1.0:
        raise InputError(
            f"q_std_velocity_um_s must be >= 0 um/s or -1 (recommended), got {slave.q_std_velocity_um_s:g}"
        )
    if slave.alarm_off_fraction < slave.alarm_on_fraction:
        raise InputError(
            f"alarm_off_fraction must be >= alarm_on_fraction ({slave.alarm_on_fraction:g}) for "
            f"hysteresis, got {slave.alarm_off_fraction:g}"
        )
    period = slave.sample_period_s
    if slave.start_time < 0.0 or abs(slave.start_time / period - round(slave.start_time / period)) > (
        GRID_TOLERANCE
    ):
        raise InputError(
            f"the start time must be >= 0 and a multiple of sample_period_s = {period:g} s (the "
            f"unbalance phase counts from t = 0), got {slave.start_time:g} s"
        )


def flowrates_ml_min(slave, system) -> tuple[tuple[float, float], tuple[float, float]]:
    """(nominal, initial) flowrates [ml/min] of the parameters, each (bearing 1's, bearing 2's): a
    ``q<b>_nominal_ml_min`` of 0 is the machine's nominal of bearing b, a ``q<b>_initial_ml_min`` of 0 its
    nominal. Each must lie in its bearing's own coefficient table range of ``system``."""
    nominal, initial = [], []
    for b, (low, high) in enumerate(system.bearing_flowrate_bounds_m3_s / ML_MIN, start=1):
        given_nominal = getattr(slave, f"q{b}_nominal_ml_min")
        given_initial = getattr(slave, f"q{b}_initial_ml_min")
        own = given_nominal if given_nominal > 0.0 else system.nominal_flowrates_m3_s[b - 1] / ML_MIN
        start = given_initial if given_initial > 0.0 else own
        if given_nominal > 0.0 and not low <= own <= high:  # named as the user gave it
            raise InputError(
                f"q{b}_nominal_ml_min must lie in bearing {b}'s coefficient table range [{low:.1f}, "
                f"{high:.1f}] ml/min, got {own:g} ml/min"
            )
        if not low <= start <= high:
            name = (
                f"q{b}_initial_ml_min"
                if given_initial > 0.0
                else f"the nominal flowrate of bearing {b} (q{b}_initial_ml_min 0)"
            )
            raise InputError(
                f"{name} must lie in bearing {b}'s coefficient table range [{low:.1f}, {high:.1f}] ml/min, "
                f"got {start:g} ml/min"
            )
        nominal.append(float(own))
        initial.append(float(start))
    return (nominal[0], nominal[1]), (initial[0], initial[1])


def estimator_model(slave, system, machine):
    """The estimator's model of ``bearing_table``: 1, the operating model following the measured speed and
    oil temperature, with the clearances the ``baseline_file``'s coast-down measured; 0, the flowrate grid
    at the start speed (no viscosity factors, the machine file's clearance)."""
    built_by = (system.speed_hz, slave.unbalance_g_mm, slave.unbalance_phase_deg, slave.sample_period_s)
    factors = _baseline_read(slave, load_clearance_factors)
    if slave.bearing_table == 1:
        # the reference grid on the dimensionless table: stored as the flowrate grid is (fmu_src.grid_store);
        # a measured clearance's is built at the first instantiation and stored for the next
        key = grid_key(slave.resources, machine, ("operating", *built_by, *(factors or ())))
        grid = load_grid(slave.resources, key)
        model = build_operating_model(
            system, machine, slave.sample_period_s, grid=grid, clearance_factors=factors
        )
        if grid is None:
            store_grid(slave.resources, key, model.reference.grid)
        return model
    if factors is not None:
        raise InputError(
            f"baseline_file {slave.baseline_file!r} holds the clearances a coast-down measured, which need "
            "bearing_table = 1"
        )
    if slave.viscosity_factor_prior_std > 0.0:
        raise InputError("viscosity_factor_prior_std > 0 needs bearing_table = 1")
    if slave.viscosity_factor_prior_std == PRESET_VALUE and preset_named(slave.preset).value(
        "viscosity_factor_prior_std", 0.0
    ):
        raise InputError(
            f"bearing_table = 0: the {slave.preset} preset estimates the viscosity factors, which need "
            "bearing_table = 1; set viscosity_factor_prior_std = 0 or bearing_table = 1"
        )
    key = grid_key(slave.resources, machine, built_by)
    grid = load_grid(slave.resources, key)  # stored by an earlier instance or the build (fmu_src.grid_store)
    model = GridAugmentedModel(system, slave.sample_period_s, grid=grid)
    if grid is None:
        store_grid(slave.resources, key, model.grid)
    return model


def baseline_prior(slave, machine):
    """(offsets prior, runout vectors) of the ``baseline_file`` parameter ((None, None) when empty; a
    relative path is relative to the resources): the prior ``baseline_age_days`` after its record with
    ``machine``'s offset drift bound, the runout None when the baseline has none."""
    if not slave.baseline_file:
        return None, None
    drift = read_probes(machine).offset_drift_m_per_day

    def prior_and_runout(path: Path):
        return load_baseline(path, SECONDS_PER_DAY * slave.baseline_age_days, drift), load_runout(path)

    return _baseline_read(slave, prior_and_runout)


def _baseline_read(slave, read):
    """``read(path)`` of the ``baseline_file`` parameter (None when it is empty; a relative path is relative
    to the resources); a one-line InputError naming the parameter when the file is bad."""
    if not slave.baseline_file:
        return None
    path = Path(slave.baseline_file)
    if not path.is_absolute() and slave.resources:
        path = Path(slave.resources) / path
    try:
        return read(path)
    except (InputError, OSError, UnicodeDecodeError) as error:
        reason = error if isinstance(error, InputError) else f"cannot read {path}: {error}"
        raise InputError(f"baseline_file {slave.baseline_file!r}: {reason}") from None


def estimator_config(
    slave,
    machine,
    nominal_ml_min: tuple[float, float],
    initial_ml_min: tuple[float, float],
    speed_hz: float,
    baseline,
    baseline_runout,
) -> EKFConfig:
    """The estimator's configuration from the parameters (field units -> SI) and the machine file's
    ``[probes]`` (mounting angle and offset prior for the sentinels; the offsets' drift, always; the scale
    factors' tolerance under a preset with the probes as installed). The
    runout vectors the filter subtracts at the model's rotor angle are the baseline's when it has them,
    else those of the ``[probes]`` ``runout_*`` keys (as ``oilwatch estimate`` chooses)."""
    omega = 2.0 * math.pi * speed_hz
    velocity_std = (
        RECOMMENDED_DISPLACEMENT_PROCESS_STD_M * omega
        if slave.q_std_velocity_um_s < 0.0
        else slave.q_std_velocity_um_s * 1e-6
    )
    probes = read_probes(machine)
    values = {p.name: getattr(slave, p.name) for p in ESTIMATOR_PARAMETERS}
    return config_from_parameters(
        values,
        slave.preset,
        probes.offset_prior_std_m,
        probe_angle_deg=probe_angle_deg(slave, machine),
        offset_random_walk_m_sqrt_s=probes.offset_random_walk_m_sqrt_s,
        probe_scale_factor_std=(
            probes.scale_factor_std if preset_named(slave.preset).offsets_from_machine else 0.0
        ),
        velocity_noise=VELOCITY_MODES[slave.velocity_channels],
        velocity_process_std_m_s=velocity_std,
        q_initial_m3_s=tuple(q * ML_MIN for q in initial_ml_min),
        q_nominal_m3_s=tuple(q * ML_MIN for q in nominal_ml_min),
        first_sample_time_s=round(slave.start_time / slave.sample_period_s) * slave.sample_period_s,
        initial_flowrate_std_m3_s=tuple(INITIAL_FLOWRATE_STD_FRACTION * q * ML_MIN for q in nominal_ml_min),
        offset_baseline=baseline,
        runout=runout_of_probes(probes) if baseline_runout is None else baseline_runout,
    )
