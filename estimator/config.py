"""Configuration of the oil-flow EKF and of the starvation alarm, validated on construction.

All values are SI (flowrates in m^3/s). The defaults are the paper's (section 3.2): measurement noise 1 um,
process-noise stds 10 um, 10 um/s and 0.1 ml/min per step, initial flowrates at the machine's nominal. The
fields the paper does not give (initial covariance, gate, convergence and alarm thresholds) are documented
where they are used. Machine facts are not defaults here: a ``None`` nominal or initial flowrate (and the
recommended velocity process noise) is taken from the model (:meth:`EKFConfig.for_model`).

:data:`ESTIMATOR_PARAMETERS` is this configuration as a user sets it (field units, ranges, descriptions): the
estimator FMU's variable table and the CLI's help are generated from it, never retyped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from models.validation import (
    InputError,
    require_finite,
    require_in_range,
    require_non_negative,
    require_positive,
)

from .runout import SlowRollVectors

ML_MIN = 1.0e-6 / 60.0
"""One millilitre per minute in m^3/s."""

VELOCITY_NOISE_MODES = ("displacement-only", "correlated", "paper")
"""How the differentiated velocities enter the update (see :mod:`estimator.measurement`)."""

INITIAL_STATE_MODES = ("zero", "static")

RECOMMENDED_DISPLACEMENT_PROCESS_STD_M = 0.1e-6
"""Displacement process-noise std per step of :meth:`EKFConfig.recommended` [m]."""


def _bounded(default: float, low: float, high: float, unit: str, description: str):
    """A field with its allowed range [low, high], unit and description (read by validation and tables)."""
    metadata = {"low": low, "high": high, "unit": unit, "description": description}
    return field(default=default, metadata=metadata)


@dataclass(frozen=True)
class AlarmConfig:
    """Thresholds of the per-bearing starvation alarm (rule in :mod:`estimator.alarm`).

    on_fraction : the alarm sets when the upper confidence bound ``q + z std`` stays below
        ``on_fraction * q_nominal`` for ``hold_on_s``.
    off_fraction : it clears when the lower bound ``q - z std`` stays above ``off_fraction * q_nominal`` for
        ``hold_off_s`` (hysteresis: ``off_fraction > on_fraction``).
    confidence_z : number of standard deviations of the bounds (2.0: one-sided 97.7 %).
    """

    on_fraction: float = _bounded(
        0.90,
        0.05,
        1.5,
        "1",
        "Alarm sets when q_est + z std stays below this fraction of the nominal flowrate for alarm_hold_on_s",
    )
    hold_on_s: float = _bounded(0.25, 0.0, 60.0, "s", "Hold time before the alarm sets")
    off_fraction: float = _bounded(
        0.95,
        0.05,
        1.5,
        "1",
        "Alarm clears when q_est - z std stays above this fraction of nominal for alarm_hold_off_s "
        "(>= alarm_on_fraction: hysteresis)",
    )
    hold_off_s: float = _bounded(1.0, 0.0, 600.0, "s", "Hold time before the alarm clears")
    confidence_z: float = _bounded(
        2.0,
        0.0,
        10.0,
        "1",
        "Confidence multiplier z of the alarm's bounds q_est +/- z std (2: one-sided 97.7 %)",
    )

    def __post_init__(self) -> None:
        for spec in fields(self):
            unit = spec.metadata["unit"]
            require_in_range(
                f"AlarmConfig.{spec.name}",
                getattr(self, spec.name),
                spec.metadata["low"],
                spec.metadata["high"],
                "" if unit == "1" else unit,
            )
        if self.off_fraction < self.on_fraction:
            raise InputError(
                f"AlarmConfig.off_fraction must be >= on_fraction ({self.on_fraction:g}) for "
                f"hysteresis, got {self.off_fraction:g}"
            )


@dataclass(frozen=True)
class OffsetBaseline:
    """A commissioning baseline (:mod:`estimator.baseline`): the nuisances' estimates at a known healthy
    condition, which become the estimator's prior.

    offsets_m, std_m : (x1, y1, x2, y2) probe zero offsets and their stds [m], std > 0.
    viscosity_factor, viscosity_factor_std : (2,) each bearing's viscosity factor and its std, or None (the
        baseline did not estimate them; the prior stays 1 +- ``viscosity_factor_prior_std``).
    unbalance, unbalance_std : (re, im) the unbalance relative to the machine file's and its stds, or None.
    covariance : the joint covariance of those estimates, in the state's order (offsets [m], then the
        viscosity factors and the unbalance when given), or None (independent). A factor read from the 1x
        orbit and the offsets that then reproduce the static position are strongly correlated; keeping the
        correlation lets a later run move both together instead of reading the factor's error as flow.
    age_s : time from the baseline record to the start of the record the estimator runs on [s]; the
        offsets' prior std is widened by the drift that time allows (:meth:`offset_prior_std_m`).
    drift_m_per_day : the probes' zero drift rate bound [m / day] (the machine file's
        ``[probes] offset_drift_um_per_day``) that ``age_s`` is multiplied by.
    """

    offsets_m: tuple[float, float, float, float]
    std_m: tuple[float, float, float, float]
    viscosity_factor: tuple[float, float] | None = None
    viscosity_factor_std: tuple[float, float] | None = None
    unbalance: tuple[float, float] | None = None
    unbalance_std: tuple[float, float] | None = None
    covariance: tuple[tuple[float, ...], ...] | None = None
    age_s: float = 0.0
    drift_m_per_day: float = 0.0

    def __post_init__(self) -> None:
        for name in ("offsets_m", "std_m"):
            values = getattr(self, name)
            if len(values) != 4:
                raise InputError(f"OffsetBaseline.{name} needs 4 values (x1, y1, x2, y2), got {len(values)}")
            for value in values:
                require_finite(f"OffsetBaseline.{name}", value)
        for value in self.std_m:
            require_positive("OffsetBaseline.std_m", value, "m")
        for name in ("viscosity_factor", "unbalance"):
            values, std = getattr(self, name), getattr(self, f"{name}_std")
            if (values is None) != (std is None):
                raise InputError(f"OffsetBaseline.{name} and {name}_std are given together or not at all")
            if values is None:
                continue
            if len(values) != 2 or len(std) != 2:
                raise InputError(f"OffsetBaseline.{name} and {name}_std need 2 values each")
            for value in values:
                require_finite(f"OffsetBaseline.{name}", value)
            for value in std:
                require_positive(f"OffsetBaseline.{name}_std", value)
        if self.covariance is not None:
            size = 4 + 2 * (self.viscosity_factor is not None) + 2 * (self.unbalance is not None)
            matrix = np.asarray(self.covariance, dtype=float)
            if matrix.shape != (size, size) or not np.isfinite(matrix).all():
                raise InputError(
                    f"OffsetBaseline.covariance must be a finite {size} x {size} matrix, got {matrix.shape}"
                )
        require_in_range("OffsetBaseline.age_s", self.age_s, 0.0, 1e9, "s")
        require_in_range("OffsetBaseline.drift_m_per_day", self.drift_m_per_day, 0.0, 1e-3, "m/day")

    def offset_prior_std_m(self) -> np.ndarray:
        """(4,) the offsets' prior std [m]: the baseline's std and the drift since it in quadrature (a drift
        of at most ``drift_m_per_day`` over ``age_s``, of unknown sign, taken as one std)."""
        return np.sqrt(np.square(self.std_m) + self._drift_variance_m2())

    def _drift_variance_m2(self) -> float:
        return (self.drift_m_per_day * self.age_s / 86400.0) ** 2

    def prior_covariance(self, viscosity: bool, unbalance: bool) -> np.ndarray | None:
        """The joint prior covariance of a filter whose nuisance states are the offsets plus the viscosity
        factors / the unbalance as flagged, when it holds exactly the baseline's (None otherwise); the
        offsets' block widened as :meth:`offset_prior_std_m`."""
        if (
            self.covariance is None
            or viscosity != (self.viscosity_factor is not None)
            or unbalance != (self.unbalance is not None)
        ):
            return None
        matrix = np.array(self.covariance, dtype=float)
        matrix[range(4), range(4)] += self._drift_variance_m2()
        return 0.5 * (matrix + matrix.T)


@dataclass(frozen=True)
class EKFConfig:
    """Everything the augmented-state EKF needs besides the model.

    Measurement and noise
        noise_std_m : std of the white displacement-measurement noise sigma_v [m].
        velocity_noise : "displacement-only" (four channels, the default: see :mod:`estimator.measurement`),
            "correlated" (eight channels, exact within-step covariance of the backward difference) or "paper"
            (eight channels, R = sigma_v^2 I as in the paper).
        displacement_process_std_m, velocity_process_std_m_s, flowrate_process_std_m3_s : process-noise stds
            per step (Q); the dynamic part goes through ``model.physical_covariance``.
    Initial estimate
        q_initial_m3_s : initial flowrate estimate, one value for both bearings or a pair (None: the nominal).
        q_nominal_m3_s : nominal flowrate; the filter's internal flowrate unit and the alarm's reference
            (None: the model's ``nominal_flowrate_m3_s``, i.e. its machine file's).
        initial_state : "zero" (the paper) or "static" (the model's static equilibrium at ``q_initial``).
        first_sample_time_s : time of the first sample fed to the filter [s], a multiple of the model's dt.
            The model's unbalance phase counts from t = 0, so a plant whose first output is its state after
            one step (t = dt) needs ``first_sample_time_s = dt``: one step of misalignment is a 27 deg phase
            error of the unbalance force at 75 Hz and 1 ms.
        initial_displacement_std_m, initial_velocity_std_m_s, initial_flowrate_std_m3_s : the initial
            covariance P0 (not given by the paper: a clearance-sized displacement error, its velocity at the
            spin speed, and a quarter of the nominal flowrate: None).
    Probes and their zero offsets
        probe_angle_deg : mounting angle of each bearing's probe pair from the model's axes (see
            :func:`estimator.measurement.probe_rotation`; 45: the API 670 pair either side of the top).
        offset_prior_std_m : prior std of each probe's zero offset; 0 (the paper's calibrated probes) keeps
            the offsets out of the state, > 0 adds four offset states (the machine file's ``[probes]``
            section gives it for a real machine, 25 um by default).
        offset_random_walk_m_sqrt_s : random-walk intensity of the offsets (drift) [m / sqrt(s)].
        unbalance_prior_std : prior std of each part of the complex unbalance ``u`` relative to the machine
            file's (initial estimate 1 + 0i); 0 keeps the machine file's unbalance exact, > 0 adds two
            unbalance states (a random walk of ``unbalance_random_walk_sqrt_s`` per sqrt(s), plus
            ``unbalance_inconsistent_std`` per step while ``model_consistent`` is false: a changed unbalance
            shows as a 1x innovation the windowed NIS test catches).
        offset_baseline : an :class:`OffsetBaseline` from a commissioning record: the offsets' initial
            estimate and prior std (it adds the offset states even when offset_prior_std_m is 0).
        runout : the probes' slow-roll (runout) vectors, :class:`estimator.runout.SlowRollVectors` (from
            ``oilwatch baseline --slow-roll-record``): subtracted from each sample at its rotor angle, their
            fit's uncertainty added to the measurement noise (None: no compensation).
    Viscosity factors (issue 14 item 1)
        viscosity_factor_prior_std : prior std of each bearing's effective viscosity factor ``f_b`` (the
            film's viscosity over the oil law's at the measured oil temperature: film heating and model error;
            prior 1); 0 (the paper's calibrated setting) keeps both factors at 1 and out of the state, > 0
            adds two random-walk states (needs a model with ``transition_full``, e.g.
            ``models.system.operating_model.OperatingAugmentedModel``).
        viscosity_factor_random_walk_sqrt_s : their random-walk intensity [1 / sqrt(s)].
    Consistency with free viscosity factors (:mod:`estimator.nuisance_start`; only while the factors are
    estimated without a baseline's prior for them)
        nuisance_shadow : the flowrate and nuisance Jacobian of each prediction is taken at a noise-free
            shadow of the dynamic state (the model run at the current estimates), not at the state
            estimate: the instrumental-variable remedy for the information a noisy state estimate fakes
            along the nearly unobservable direction of (flowrates, offsets, unbalance, factors).
        nuisance_settling_time_constants : for this many time constants of the model's least damped mode
            the flowrates and nuisances stay out of the Jacobian while the dynamic states settle, then start
            from their prior (0: off).
        nuisance_information_floor : (with the shadow Jacobian) the flowrates' std is kept at or above the
            posterior Cramer-Rao bound of the filter's own configuration, evaluated along the record at the
            estimates (:class:`estimator.nuisance_start.InformationFloor`).
    Innovation gate and probe health (see :mod:`estimator.channels`)
        gate_tail_probability : a channel whose squared standardized innovation exceeds the chi-square(1)
            quantile ``1 - p`` times its recent innovation power is rejected (0 disables the gate).
        gate_scale_window_s : time constant of that fading-memory innovation power [s].
        probe_range_m : a reading with ``|x| >`` this is physically impossible (the probe is out of range);
            None: the model's radial clearance (``model.clearance_m``) plus ``probe_range_margin_m``, or no
            range check when the model does not give its clearance.
        probe_dead_s, probe_stuck_s, probe_rejected_s : non-finite, unchanged (within
            ``probe_stuck_tolerance_m``), or alone rejected by the gate for this long in a row flags a probe
            faulty; probe_recover_s : a faulty probe returns after looking healthy for this long in a row.
    Change detection and model consistency (see :mod:`estimator.ekf`)
        change_window_s : time constant of the fading-memory mean of each channel's standardized innovation.
        change_tail_probability : a bearing whose two channels' mean innovation exceeds the chi-square(2)
            quantile ``1 - p`` of its null distribution is changing: its flowrate gets the extra process noise
        change_flowrate_std_fraction : (std per step, as a fraction of nominal) while the test fires.
        consistency_window_s, consistency_tail_probability : ``model_consistent`` is false when the sum of the
            NIS over the last window exceeds the chi-square quantile ``1 - p`` of its degrees of freedom.
    Convergence flag
        converged_std_fraction : both flowrate stds below this fraction of nominal, and
        converged_drift_fraction : both estimates moved less than this fraction of nominal over
        converged_window_s.
    """

    noise_std_m: float = 1.0e-6
    velocity_noise: str = "displacement-only"
    displacement_process_std_m: float = 10.0e-6
    velocity_process_std_m_s: float = 10.0e-6
    flowrate_process_std_m3_s: float = 0.1 * ML_MIN
    q_initial_m3_s: float | tuple[float, float] | None = None
    q_nominal_m3_s: float | None = None
    initial_state: str = "zero"
    first_sample_time_s: float = 0.0
    initial_displacement_std_m: float = 100.0e-6
    initial_velocity_std_m_s: float = 0.05
    initial_flowrate_std_m3_s: float | None = None
    probe_angle_deg: float = 0.0
    offset_prior_std_m: float = 0.0
    offset_random_walk_m_sqrt_s: float = 0.2e-6
    offset_baseline: OffsetBaseline | None = None
    runout: SlowRollVectors | None = None
    viscosity_factor_prior_std: float = 0.0
    viscosity_factor_random_walk_sqrt_s: float = 0.002
    nuisance_shadow: bool = True
    nuisance_settling_time_constants: float = 5.0
    nuisance_information_floor: bool = True
    unbalance_prior_std: float = 0.0
    unbalance_random_walk_sqrt_s: float = 0.02
    unbalance_inconsistent_std: float = 0.01
    gate_tail_probability: float = 1.0e-6
    gate_scale_window_s: float = 0.1
    probe_range_m: float | None = None
    probe_range_margin_m: float = 100.0e-6
    probe_dead_s: float = 0.05
    probe_stuck_s: float = 0.1
    probe_stuck_tolerance_m: float = 0.0
    probe_rejected_s: float = 0.05
    probe_recover_s: float = 0.5
    change_window_s: float = 0.05
    change_tail_probability: float = 1.0e-3
    change_flowrate_std_fraction: float = 0.003
    consistency_window_s: float = 1.0
    consistency_tail_probability: float = 1.0e-3
    converged_std_fraction: float = 0.03
    converged_drift_fraction: float = 0.01
    converged_window_s: float = 1.0
    alarm: AlarmConfig = field(default_factory=AlarmConfig)

    def __post_init__(self) -> None:
        require_positive("EKFConfig.noise_std_m", self.noise_std_m, "m")
        if self.velocity_noise not in VELOCITY_NOISE_MODES:
            raise InputError(
                f"EKFConfig.velocity_noise must be one of {VELOCITY_NOISE_MODES}, got {self.velocity_noise!r}"
            )
        if self.initial_state not in INITIAL_STATE_MODES:
            raise InputError(
                f"EKFConfig.initial_state must be one of {INITIAL_STATE_MODES}, got {self.initial_state!r}"
            )
        for name in (
            "displacement_process_std_m",
            "velocity_process_std_m_s",
            "flowrate_process_std_m3_s",
        ):
            if not (name == "velocity_process_std_m_s" and self.velocity_process_std_m_s is None):
                require_non_negative(f"EKFConfig.{name}", getattr(self, name))
        require_non_negative("EKFConfig.first_sample_time_s", self.first_sample_time_s, "s")
        for name in (
            "q_nominal_m3_s",
            "initial_displacement_std_m",
            "initial_velocity_std_m_s",
            "initial_flowrate_std_m3_s",
            "converged_std_fraction",
            "converged_drift_fraction",
            "converged_window_s",
        ):
            if getattr(self, name) is not None:
                require_positive(f"EKFConfig.{name}", getattr(self, name))
        if self.q_initial_m3_s is not None:
            for value in self.q_initial_pair():
                require_positive("EKFConfig.q_initial_m3_s", value, "m^3/s")
        require_in_range("EKFConfig.gate_tail_probability", self.gate_tail_probability, 0.0, 0.5)
        if self.probe_range_m is not None:
            require_positive("EKFConfig.probe_range_m", self.probe_range_m, "m")
        require_in_range("EKFConfig.probe_angle_deg", self.probe_angle_deg, -360.0, 360.0, "deg")
        for name in (
            "probe_range_margin_m",
            "probe_stuck_tolerance_m",
            "change_flowrate_std_fraction",
            "offset_prior_std_m",
            "offset_random_walk_m_sqrt_s",
            "unbalance_prior_std",
            "unbalance_random_walk_sqrt_s",
            "unbalance_inconsistent_std",
            "viscosity_factor_random_walk_sqrt_s",
            "nuisance_settling_time_constants",
        ):
            require_non_negative(f"EKFConfig.{name}", getattr(self, name))
        for name in (
            "gate_scale_window_s",
            "probe_dead_s",
            "probe_stuck_s",
            "probe_rejected_s",
            "probe_recover_s",
            "change_window_s",
            "consistency_window_s",
        ):
            require_in_range(f"EKFConfig.{name}", getattr(self, name), 1e-6, 600.0, "s")
        require_in_range("EKFConfig.viscosity_factor_prior_std", self.viscosity_factor_prior_std, 0.0, 0.5)
        require_in_range("EKFConfig.change_tail_probability", self.change_tail_probability, 1e-15, 0.5)
        require_in_range(
            "EKFConfig.consistency_tail_probability", self.consistency_tail_probability, 1e-15, 0.5
        )
        if self.runout is not None and not isinstance(self.runout, SlowRollVectors):
            raise InputError(f"EKFConfig.runout must be SlowRollVectors, got {type(self.runout)!r}")
        if self.offset_baseline is not None and not isinstance(self.offset_baseline, OffsetBaseline):
            raise InputError(
                f"EKFConfig.offset_baseline must be an OffsetBaseline, got {type(self.offset_baseline)!r}"
            )
        if not isinstance(self.alarm, AlarmConfig):
            raise InputError(f"EKFConfig.alarm must be an AlarmConfig, got {type(self.alarm)!r}")

    @classmethod
    def recommended(cls, speed_hz: float | None = None, **overrides) -> EKFConfig:
        """The paper's configuration with a process noise matched to the model error instead of the paper's.

        Dynamic process-noise stds of 0.1 um and 0.1 um x Omega per step (Omega = 2 pi speed_hz; None: the
        model's speed, resolved by :meth:`for_model`). The truth
        has no process noise; what Q must cover is the model error, far below the paper's 10 um per step.
        Measured on the issue-4 plant (Newmark full model; reduced grid model in the filter; sigma 1 um):
        NIS/m 0.99 against 0.14 with the paper's values, mean |error| of constant flowrates 0.09 % against
        0.59 %, starvation alarm 0.45-0.6 s after the centre of a sudden 25 % drop against 1.2-1.5 s.
        ``overrides`` replace any other field.
        """
        velocity = None
        if speed_hz is not None:
            omega = 2.0 * math.pi * require_positive("speed_hz", speed_hz, "Hz")
            velocity = RECOMMENDED_DISPLACEMENT_PROCESS_STD_M * omega
        values = {
            "displacement_process_std_m": RECOMMENDED_DISPLACEMENT_PROCESS_STD_M,
            "velocity_process_std_m_s": velocity,
        }
        values.update(overrides)
        return cls(**values)

    def for_model(self, model) -> EKFConfig:
        """This configuration with the machine facts it left open (None) taken from ``model``.

        ``q_nominal_m3_s`` from ``model.nominal_flowrate_m3_s``, ``q_initial_m3_s`` = the nominal,
        ``initial_flowrate_std_m3_s`` = a quarter of it, and a None velocity process noise (the recommended
        one) = 0.1 um x 2 pi ``model.speed_hz``. An InputError names what the model lacks.
        """
        values = {}
        nominal = self.q_nominal_m3_s
        if nominal is None:
            nominal = getattr(model, "nominal_flowrate_m3_s", None)
            if nominal is None:
                raise InputError(
                    "EKFConfig.q_nominal_m3_s: give it, or use a model with nominal_flowrate_m3_s"
                )
            values["q_nominal_m3_s"] = float(nominal)
        if self.q_initial_m3_s is None:
            values["q_initial_m3_s"] = float(nominal)
        if self.initial_flowrate_std_m3_s is None:
            values["initial_flowrate_std_m3_s"] = INITIAL_FLOWRATE_STD_FRACTION * float(nominal)
        if self.velocity_process_std_m_s is None:
            speed = getattr(model, "speed_hz", None)
            if speed is None:
                raise InputError("EKFConfig.velocity_process_std_m_s: give it, or use a model with speed_hz")
            omega = 2.0 * math.pi * float(speed)
            values["velocity_process_std_m_s"] = RECOMMENDED_DISPLACEMENT_PROCESS_STD_M * omega
        return replace(self, **values) if values else self

    def q_initial_pair(self) -> tuple[float, float]:
        """The initial flowrates (q1, q2) [m^3/s]."""
        value = self.q_initial_m3_s
        if isinstance(value, tuple | list):
            if len(value) != 2:
                raise InputError(
                    f"EKFConfig.q_initial_m3_s must be one value or a pair, got {len(value)} values"
                )
            return (
                require_finite("EKFConfig.q_initial_m3_s", value[0]),
                require_finite("EKFConfig.q_initial_m3_s", value[1]),
            )
        number = require_finite("EKFConfig.q_initial_m3_s", value)
        return (number, number)


INITIAL_FLOWRATE_STD_FRACTION = 0.25
"""Default initial flowrate std (P0) as a fraction of the nominal flowrate."""


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
# description) and its estimate (outputs, see NuisanceOutput). The estimator FMU and `oilwatch estimate`
# generate their variables and columns from these rows; a new nuisance is one row in each.
# The probes' mounting angle is a machine fact both FMUs share: fmu_src/machine_parameters.py declares it.
OFFSET_PRIOR_FROM_MACHINE = -1.0
"""Value of ``offset_prior_std_um`` standing for the machine file's ``[probes] offset_prior_std_um``."""
NUISANCE_PRIORS = (
    ("offset_prior_std_um", "offset_prior_std_m", "um", 1e-6, OFFSET_PRIOR_FROM_MACHINE, 1000.0,
     "Prior std of each probe's zero offset; 0: the offsets are known to be zero (the paper's calibrated "
     "probes); > 0 estimates four offset states drifting as the machine file's [probes] "
     "offset_random_walk_um_sqrt_s; -1: the machine file's [probes] offset_prior_std_um (a real machine; "
     "bundled turbine 25 um). A baseline_file sets the offsets' prior instead"),
    ("unbalance_prior_std", "unbalance_prior_std", "1", 1.0, 0.0, 10.0,
     "Prior std of each part of the unbalance relative to the machine file's (estimate starts at 1 + 0i); "
     "0: the machine file's unbalance is exact; > 0 estimates it as a complex random walk"),
)  # fmt: skip


@dataclass(frozen=True)
class NuisanceOutput:
    """One estimated nuisance as outputs: per label, the estimate ``<stem>_<label>[_<unit>]`` and its std
    ``<stem>_<label>_std[_<unit>]`` (no unit suffix for unit "1").

    estimate, std : names of the :class:`estimator.ekf.OilFlowEKF` properties giving the (n,) SI values;
    scale : user value = scale x SI value; description : with ``{label}`` for the component; known : the
    estimates' values (user unit) while the nuisance is known (not estimated; None: zeros).
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


def _estimator_parameters() -> tuple[BoundaryParameter, ...]:
    recommended = EKFConfig.recommended()
    own = (
        ("noise_um", "noise_std_m", "um", 1e-6, 1e-3, None,
         "Std of the white measurement noise of each probe (R = noise^2)"),
        ("q_std_displacement_um", "displacement_process_std_m", "um", 1e-6, 0.0, None,
         "Process-noise std per step of every displacement state. Default: the recommended tuning; the "
         "paper's 10 um makes the filter inconsistent (NIS/m 0.14), more biased and slower to alarm"),
        ("q_std_flow_ml_min", "flowrate_process_std_m3_s", "ml/min", ML_MIN, 0.0, None,
         "Process-noise std per step of each flowrate state (paper and recommended: 0.1 ml/min)"),
        ("viscosity_factor_prior_std", "viscosity_factor_prior_std", "1", 1.0, 0.0, 0.5,
         "Prior std of each bearing's viscosity factor (film over the oil law at the measured temperature); "
         "0: known (1, the paper's calibrated setting); > 0 estimates both (needs bearing_table = 1)"),
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
        BoundaryParameter(name, key, unit, scale, getattr(recommended, key) / scale, low, high, text)
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


def config_from_parameters(values: dict[str, float], **fixed) -> EKFConfig:
    """An :class:`EKFConfig` (recommended tuning) from user values of :data:`ESTIMATOR_PARAMETERS` by name
    (missing ones keep their default) and further SI fields ``fixed``."""
    direct, alarm = {}, {}
    for parameter in ESTIMATOR_PARAMETERS:
        value = parameter.si(values.get(parameter.name, parameter.default))
        if parameter.field.startswith("alarm."):
            alarm[parameter.field.removeprefix("alarm.")] = value
        else:
            direct[parameter.field] = value
    return EKFConfig.recommended(**direct, alarm=AlarmConfig(**alarm), **fixed)


def config_field_names() -> tuple[str, ...]:
    """Names of the :class:`EKFConfig` fields (for wrappers such as the FMU that map their parameters)."""
    return tuple(f.name for f in fields(EKFConfig))
