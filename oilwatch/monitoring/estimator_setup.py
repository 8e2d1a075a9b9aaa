"""The estimator ``oilwatch estimate`` runs a record through: its model and its configuration.

Configured as the OilFlowEKF FMU's defaults (``EKFConfig.recommended`` at the model's speed, the probes'
``noise_um``, initial flowrates at nominal, zero initial states) plus the record's probe nuisances (see
:mod:`oilwatch.monitoring.estimate`). The model is the machine file's reduced rotor-bearing system sampled at
1 kHz (:data:`ESTIMATOR_DT_S`), at the nominal point or as the operating model that follows speed and oil
temperature; each is built once per process.
"""

from __future__ import annotations

from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.estimator.offset_baseline import OffsetBaseline
from oilwatch.estimator.runout import SlowRollVectors
from oilwatch.models.machine import Machine, load_machine
from oilwatch.models.probes import Probes
from oilwatch.models.validation import InputError

ESTIMATOR_DT_S = 1e-3
"""The estimator's sampling period (its discrete model's step, as the FMU's default)."""
_MODELS: dict[tuple, object] = {}
_REDUCED: dict[str | None, object] = {}


def estimator_model(
    machine_file: str | None,
    dt_s: float = ESTIMATOR_DT_S,
    follow: bool = False,
    machine: Machine | None = None,
    clearance_factors: tuple[float, ...] | None = None,
):
    """The estimator's model of a machine file: the reduced system at the nominal point (the estimator FMU's
    ``bearing_table = 0``) or, with ``follow``, its operating model on the dimensionless tables
    (``bearing_table = 1``), with the bearings' ``clearance_factors`` a coast-down measured (a baseline's:
    :func:`oilwatch.estimator.baseline.load_clearance_factors`; None: the machine file's clearance); each
    built once per process (a Dask worker keeps it), from ``machine`` when the caller has already loaded the
    file. A filter built on the operating model resets it to its just-built state (``OilFlowEKF.reset``: no
    correction centre survives), so a record's estimates do not depend on what ran on it before
    (tests/test_estimate_model_cache.py)."""
    if clearance_factors is not None and not follow:
        raise InputError(
            "a baseline with measured clearances needs the model that follows the operating point (the "
            "machine preset's, or --operating-point follow)"
        )
    key = (machine_file, dt_s, follow, clearance_factors)
    if key not in _MODELS:
        machine = machine if machine is not None else load_machine(machine_file)
        system = _REDUCED.get(machine_file)
        if system is None:
            from oilwatch.models.system.factory import build_system

            system = _REDUCED[machine_file] = build_system(machine, reduced=True)
        if follow:
            from oilwatch.models.system.operating_model import build_operating_model

            model = build_operating_model(system, machine, dt_s, clearance_factors=clearance_factors)
        else:
            from oilwatch.models.system.augmented import GridAugmentedModel

            model = GridAugmentedModel(system, dt_s)
        _MODELS[key] = model
    return _MODELS[key]


def estimator_config(
    speed_hz: float,
    noise_um: float,
    first_sample_time_s: float,
    probes: Probes | None = None,
    baseline: OffsetBaseline | None = None,
    probe_angle_deg: float = 0.0,
    runout: SlowRollVectors | None = None,
    viscosity_factor_prior_std: float = 0.0,
    unbalance_prior_std: float = 0.0,
    model_mismatch_action: bool = True,
) -> EKFConfig:
    """The OilFlowEKF FMU's default configuration with the machine's probe nuisances (module docstring).

    ``probes``: the machine file's ``[probes]`` offsets prior, drift and scale factors' std (None: offsets
    known and scale factors exact, the FMU's default); ``baseline``: a commissioning baseline's offsets
    prior (the FMU's ``baseline_file``);
    ``probe_angle_deg``: the probe pairs' mounting angle when the samples are along the probes' axes (the
    FMU's ``probe_angle_deg``; 0: (x, y) positions); ``runout``: the probes' slow-roll vectors, subtracted
    from each sample at its rotor angle (the samples must then be along the probes' axes);
    ``viscosity_factor_prior_std``, ``unbalance_prior_std``: the viscosity factors' and the unbalance's
    prior stds (0: known); ``model_mismatch_action``: the FMU preset's (estimator.baseline_change)."""
    nuisance = {
        "viscosity_factor_prior_std": viscosity_factor_prior_std,
        "unbalance_prior_std": unbalance_prior_std,
        "model_mismatch_action": model_mismatch_action,
    }
    if probes is not None:
        nuisance |= {
            "offset_prior_std_m": probes.offset_prior_std_m,
            "offset_random_walk_m_sqrt_s": probes.offset_random_walk_m_sqrt_s,
            "probe_scale_factor_std": probes.scale_factor_std,
        }
    return EKFConfig.recommended(
        speed_hz=speed_hz,
        noise_std_m=noise_um * 1e-6,
        first_sample_time_s=first_sample_time_s,
        offset_baseline=baseline,
        probe_angle_deg=probe_angle_deg,
        runout=runout,
        **nuisance,
    )
