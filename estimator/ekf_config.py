"""Configuration of the oil-flow EKF, validated on construction, and its named presets.

All values are SI (flowrates in m^3/s). The defaults are the paper's (section 3.2): measurement noise 1 um,
process-noise stds 10 um, 10 um/s and 0.1 ml/min per step, initial flowrates at the machine's nominal. The
fields the paper does not give (initial covariance, gate, convergence and alarm thresholds) are documented
where they are used. Machine facts are not defaults here: a ``None`` nominal or initial flowrate (and the
recommended velocity process noise) is taken from the model (:meth:`EKFConfig.for_model`).

:data:`PRESETS` name the configurations a user starts from (:meth:`EKFConfig.preset`): ``machine``, the
default of the estimator FMU, ``oilwatch baseline`` and ``oilwatch estimate`` (a real machine: the probe
offsets, the unbalance and the bearings' viscosity factors estimated, the bearing table that follows speed and
oil temperature, and no action on an estimate the filter finds inconsistent), and ``paper``, the paper's
calibrated filter (the nuisances known, the flowrate grid at one speed) that the paper's scenarios, ``oilwatch
report`` and ``oilwatch study`` run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from oilwatch.models.validation import (
    InputError,
    require_finite,
    require_in_range,
    require_non_negative,
    require_positive,
)

from .alarm_config import AlarmConfig
from .offset_baseline import OffsetBaseline
from .runout import SlowRollVectors

ML_MIN = 1.0e-6 / 60.0
"""One millilitre per minute in m^3/s."""

VELOCITY_NOISE_MODES = ("displacement-only", "paper")
"""How the differentiated velocities enter the update (see :mod:`oilwatch.estimator.measurement`)."""

INITIAL_STATE_MODES = ("zero", "static")

RECOMMENDED_DISPLACEMENT_PROCESS_STD_M = 0.1e-6
"""Displacement process-noise std per step of :meth:`EKFConfig.recommended` [m]."""


# Fixed design choices of the filter: nobody needs to change them per machine or per run, so they are
# constants with their reason rather than configuration.
INITIAL_DISPLACEMENT_STD_M = 100.0e-6
"""Initial std of each dynamic displacement state: clearance-sized (the paper gives no P0)."""
INITIAL_VELOCITY_STD_M_S = 0.05
"""Initial std of each dynamic velocity state: that displacement at the spin speed."""
VISCOSITY_FACTOR_RANDOM_WALK_SQRT_S = 0.002
"""Random-walk intensity of the viscosity factors [1/sqrt(s)]: a film heating over minutes, not seconds."""
UNBALANCE_RANDOM_WALK_SQRT_S = 0.02
"""Random-walk intensity of each part of the relative complex unbalance [1/sqrt(s)]."""
UNBALANCE_INCONSISTENT_STD = 0.01
"""Extra unbalance std per step while ``model_consistent`` is false: a changed unbalance shows as a 1x
innovation that the windowed NIS test catches, and the unbalance states then follow it."""
GATE_SCALE_WINDOW_S = 0.1
"""Time constant of the fading-memory innovation power the gate scales its threshold by [s]."""
PROBE_RANGE_MARGIN_M = 100.0e-6
"""A reading beyond the model's radial clearance plus this is physically impossible (probe out of range)."""
PROBE_DEAD_S = 0.05
"""Non-finite for this long in a row flags a probe dead [s]: longer than a dropout of a few samples."""
PROBE_STUCK_S = 0.1
"""Unchanged for this long in a row flags a probe stuck [s]: a 1x orbit never holds still that long."""
PROBE_STUCK_TOLERANCE_M = 0.0
"""A reading within this of the last one counts as unchanged: 0, a live probe's noise always moves it."""
PROBE_REJECTED_S = 0.05
"""Rejected alone by the gate for this long in a row flags a probe faulty [s]."""
PROBE_RECOVER_S = 0.5
"""A faulty probe returns after looking healthy for this long in a row [s]."""
CHANGE_WINDOW_S = 0.05
"""Time constant of the fading-memory mean of each channel's standardized innovation [s]."""
CHANGE_TAIL_PROBABILITY = 1.0e-3
"""A bearing is changing when its two channels' mean innovation exceeds the chi-square(2) quantile 1 - p."""
CONSISTENCY_WINDOW_S = 1.0
"""Window of the time-average NIS test of ``model_consistent`` [s] (Bar-Shalom et al. sec. 5.4.2)."""
CONSISTENCY_TAIL_PROBABILITY = 1.0e-3
"""``model_consistent`` is false above the chi-square quantile 1 - p of the window's degrees of freedom."""
CONVERGED_STD_FRACTION = 0.03
"""``converged`` needs both flowrate stds below this fraction of nominal."""
CONVERGED_DRIFT_FRACTION = 0.01
"""... and both estimates moved less than this fraction of nominal over :data:`CONVERGED_WINDOW_S`."""
CONVERGED_WINDOW_S = 1.0
"""The window of the convergence flag [s]."""


@dataclass(frozen=True)
class EKFConfig:
    """Everything the augmented-state EKF needs besides the model.

    Measurement and noise
        noise_std_m : std of the white displacement-measurement noise sigma_v [m].
        velocity_noise : "displacement-only" (four channels, the default) or "paper" (eight channels, the
            differentiated velocities too, R = sigma_v^2 I as in the paper); see
            :mod:`oilwatch.estimator.measurement`.
        displacement_process_std_m, velocity_process_std_m_s, flowrate_process_std_m3_s : process-noise stds
            per step (Q); the dynamic part goes through ``model.physical_covariance``.
    Initial estimate
        q_initial_m3_s : initial flowrate estimate, one value for both bearings or a pair (None: each
            bearing's nominal).
        q_nominal_m3_s : each bearing's nominal flowrate, one value for both or a pair (q1, q2); each
            bearing's internal flowrate unit and its alarm's reference (None: the model's
            ``nominal_flowrates_m3_s``, i.e. its machine file's).
        initial_state : "zero" (the paper) or "static" (the model's static equilibrium at ``q_initial``).
        first_sample_time_s : time of the first sample fed to the filter [s], a multiple of the model's dt.
            The model's unbalance phase counts from t = 0, so a plant whose first output is its state after
            one step (t = dt) needs ``first_sample_time_s = dt``: one step of misalignment is a 27 deg phase
            error of the unbalance force at 75 Hz and 1 ms.
        initial_flowrate_std_m3_s : initial std of each flowrate, one value for both or a pair (not given by
            the paper; None: a quarter of each bearing's nominal flowrate). The dynamic states' initial stds
            are :data:`INITIAL_DISPLACEMENT_STD_M` and :data:`INITIAL_VELOCITY_STD_M_S`.
    Probes and their zero offsets
        probe_angle_deg : mounting angle of each bearing's probe pair from the model's axes (see
            :func:`oilwatch.estimator.measurement.probe_rotation`; 45: the API 670 pair either side of the
            top).
        offset_prior_std_m : prior std of each probe's zero offset; 0 (the paper's calibrated probes) keeps
            the offsets out of the state, > 0 adds four offset states (the machine file's ``[probes]``
            section gives it for a real machine, 25 um by default).
        offset_random_walk_m_sqrt_s : random-walk intensity of the offsets (drift) [m / sqrt(s)].
        unbalance_prior_std : prior std of each part of the complex unbalance ``u`` relative to the machine
            file's (initial estimate 1 + 0i); 0 keeps the machine file's unbalance exact, > 0 adds two
            unbalance states (a random walk of :data:`UNBALANCE_RANDOM_WALK_SQRT_S` per sqrt(s), plus
            :data:`UNBALANCE_INCONSISTENT_STD` per step while ``model_consistent`` is false).
        probe_scale_factor_std : each probe's scale-factor error std relative to its nominal (the machine
            file's ``[probes] scale_factor_tolerance_pct`` / sqrt(3) for a real machine; 0: calibrated). Not a
            state: its effect on the flowrates is added to their published std as a consider term
            (:class:`oilwatch.estimator.nuisance_start.InformationFloor`).
        offset_baseline : an :class:`OffsetBaseline` from a commissioning record: the offsets' initial
            estimate and prior std (it adds the offset states even when offset_prior_std_m is 0).
        runout : the probes' slow-roll (runout) vectors, :class:`oilwatch.estimator.runout.SlowRollVectors`
        (from
            ``oilwatch baseline --slow-roll-record``): subtracted from each sample at its rotor angle, their
            fit's uncertainty added to the measurement noise (None: no compensation).
    Viscosity factors
        viscosity_factor_prior_std : prior std of each bearing's effective viscosity factor ``f_b`` (the
            film's viscosity over the oil law's at the measured oil temperature: film heating and model error;
            prior 1); 0 (the paper's calibrated setting) keeps both factors at 1 and out of the state, > 0
            adds two random-walk states (needs a model with ``transition_full``, e.g.
            ``oilwatch.models.system.operating_model.OperatingAugmentedModel``).
    Consistency with free viscosity factors (:mod:`oilwatch.estimator.nuisance_start`; only while the factors
    are estimated without a baseline's prior for them)
        nuisance_shadow : the flowrate and nuisance Jacobian of each prediction is taken at a noise-free
            shadow of the dynamic state (the model run at the current estimates), not at the state
            estimate: the instrumental-variable remedy for the information a noisy state estimate fakes
            along the nearly unobservable direction of (flowrates, offsets, unbalance, factors).
        nuisance_settling_time_constants : for this many time constants of the model's least damped mode
            the flowrates and nuisances stay out of the Jacobian while the dynamic states settle, then start
            from their prior (0: off).
        nuisance_information_floor : (with the shadow Jacobian) the flowrates' std is kept at or above the
            posterior Cramer-Rao bound of the filter's own configuration, evaluated along the record at the
            estimates (:class:`oilwatch.estimator.nuisance_start.InformationFloor`).
    Innovation gate (see :mod:`oilwatch.estimator.channels`)
        gate_tail_probability : a channel whose squared standardized innovation exceeds the chi-square(1)
            quantile ``1 - p`` times its recent innovation power is rejected (0 disables the gate).
        change_flowrate_std_fraction : extra flowrate process noise (std per step, as a fraction of nominal)
            while a bearing's change test fires (:data:`CHANGE_WINDOW_S`, :data:`CHANGE_TAIL_PROBABILITY`).
    Model mismatch (see :mod:`oilwatch.estimator.baseline_change`, whose constants set its holds and tests)
        model_mismatch_action : while the data are not the model's (``model_consistent`` false, or the
            filter's flowrate far from the static change relative to the baseline), the filter's estimate
            does not act on its own: the published flowrates and the alarm come from the static change
            relative to the baseline (``offset_baseline`` with its static reference), or the alarm is held
            and the std the estimate's RMS error under the flowrates' prior; False: the filter's estimate
            throughout (the paper).
    The probe-health, consistency and convergence thresholds are the module's constants.
    """

    noise_std_m: float = 1.0e-6
    velocity_noise: str = "displacement-only"
    displacement_process_std_m: float = 10.0e-6
    velocity_process_std_m_s: float = 10.0e-6
    flowrate_process_std_m3_s: float = 0.1 * ML_MIN
    q_initial_m3_s: float | tuple[float, float] | None = None
    q_nominal_m3_s: float | tuple[float, float] | None = None
    initial_state: str = "zero"
    first_sample_time_s: float = 0.0
    initial_flowrate_std_m3_s: float | tuple[float, float] | None = None
    probe_angle_deg: float = 0.0
    offset_prior_std_m: float = 0.0
    offset_random_walk_m_sqrt_s: float = 0.2e-6
    probe_scale_factor_std: float = 0.0
    offset_baseline: OffsetBaseline | None = None
    runout: SlowRollVectors | None = None
    viscosity_factor_prior_std: float = 0.0
    nuisance_shadow: bool = True
    nuisance_settling_time_constants: float = 5.0
    nuisance_information_floor: bool = True
    unbalance_prior_std: float = 0.0
    gate_tail_probability: float = 1.0e-6
    change_flowrate_std_fraction: float = 0.003
    model_mismatch_action: bool = True
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
        for name in ("q_nominal_m3_s", "initial_flowrate_std_m3_s", "q_initial_m3_s"):
            if getattr(self, name) is not None:
                for value in self._pair(name):
                    require_positive(f"EKFConfig.{name}", value, "m^3/s")
        require_in_range("EKFConfig.gate_tail_probability", self.gate_tail_probability, 0.0, 0.5)
        require_in_range("EKFConfig.probe_angle_deg", self.probe_angle_deg, -360.0, 360.0, "deg")
        for name in (
            "change_flowrate_std_fraction",
            "offset_prior_std_m",
            "offset_random_walk_m_sqrt_s",
            "unbalance_prior_std",
            "nuisance_settling_time_constants",
        ):
            require_non_negative(f"EKFConfig.{name}", getattr(self, name))
        require_in_range("EKFConfig.viscosity_factor_prior_std", self.viscosity_factor_prior_std, 0.0, 0.5)
        require_in_range("EKFConfig.probe_scale_factor_std", self.probe_scale_factor_std, 0.0, 0.3)
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
        has no process noise; what Q must cover is the model error, far below the paper's 10 um per step:
        with the paper's values the filter is conservative (NIS far below its degrees of freedom), biased
        and slow to alarm (the docs' tuning table).
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

    @classmethod
    def preset(cls, name: str | None = None, speed_hz: float | None = None, **overrides) -> EKFConfig:
        """:meth:`recommended` with the fields of the preset ``name`` (:data:`PRESETS`; None: the default,
        :data:`DEFAULT_PRESET`), then ``overrides``.
        The machine facts a preset leaves to the machine file (the offsets' prior: ``Preset.
        offsets_from_machine``) and the model it runs on (``Preset.follow_operating_point``) are the
        caller's."""
        values = dict(preset_named(DEFAULT_PRESET if name is None else name).fields)
        values.update(overrides)
        return cls.recommended(speed_hz, **values)

    def for_model(self, model) -> EKFConfig:
        """This configuration with the machine facts it left open (None) taken from ``model``.

        ``q_nominal_m3_s`` from ``model.nominal_flowrates_m3_s`` (each bearing's), ``q_initial_m3_s`` = the
        nominals, ``initial_flowrate_std_m3_s`` = a quarter of each, and a None velocity process noise (the
        recommended one) = 0.1 um x 2 pi ``model.speed_hz``. An InputError names what the model lacks.
        """
        values = {}
        if self.q_nominal_m3_s is None:
            given = getattr(model, "nominal_flowrates_m3_s", None)
            if given is None:
                raise InputError(
                    "EKFConfig.q_nominal_m3_s: give it, or use a model with nominal_flowrates_m3_s"
                )
            # checked as a pair (its length, each > 0) when the replace below validates the result
            values["q_nominal_m3_s"] = tuple(float(q) for q in given)
        nominal = values.get("q_nominal_m3_s") or self.q_nominal_pair()
        if self.q_initial_m3_s is None:
            values["q_initial_m3_s"] = nominal
        if self.initial_flowrate_std_m3_s is None:
            values["initial_flowrate_std_m3_s"] = tuple(INITIAL_FLOWRATE_STD_FRACTION * q for q in nominal)
        if self.velocity_process_std_m_s is None:
            speed = getattr(model, "speed_hz", None)
            if speed is None:
                raise InputError("EKFConfig.velocity_process_std_m_s: give it, or use a model with speed_hz")
            omega = 2.0 * math.pi * float(speed)
            values["velocity_process_std_m_s"] = RECOMMENDED_DISPLACEMENT_PROCESS_STD_M * omega
        return replace(self, **values) if values else self

    def q_initial_pair(self) -> tuple[float, float]:
        """The initial flowrates (q1, q2) [m^3/s]."""
        return self._pair("q_initial_m3_s")

    def q_nominal_pair(self) -> tuple[float, float]:
        """Each bearing's nominal flowrate (q1, q2) [m^3/s]."""
        return self._pair("q_nominal_m3_s")

    def initial_flowrate_std_pair(self) -> tuple[float, float]:
        """Each flowrate's initial std (q1, q2) [m^3/s]."""
        return self._pair("initial_flowrate_std_m3_s")

    def _pair(self, name: str) -> tuple[float, float]:
        """The per-bearing field ``name`` as (bearing 1's, bearing 2's): one value is both bearings'."""
        value = getattr(self, name)
        if isinstance(value, tuple | list):
            if len(value) != 2:
                raise InputError(f"EKFConfig.{name} must be one value or a pair, got {len(value)} values")
            return (
                require_finite(f"EKFConfig.{name}", value[0]),
                require_finite(f"EKFConfig.{name}", value[1]),
            )
        number = require_finite(f"EKFConfig.{name}", value)
        return (number, number)


INITIAL_FLOWRATE_STD_FRACTION = 0.25
"""Default initial flowrate std (P0) as a fraction of the nominal flowrate."""


@dataclass(frozen=True)
class Preset:
    """A named starting configuration (:data:`PRESETS`).

    name, description : as the user sees them. fields : :class:`EKFConfig` fields over
    :meth:`EKFConfig.recommended` (as (name, value) pairs). offsets_from_machine : the probes as installed:
    their offsets are estimated with the machine file's ``[probes]`` prior and their scale factors known to
    its ``scale_factor_tolerance_pct`` (False: calibrated probes, offsets zero and scale factors exact).
    follow_operating_point :
    the estimator's model follows the measured speed and oil temperature on the dimensionless bearing tables
    (the estimator FMU's ``bearing_table = 1``; False: the flowrate grid at one speed).
    """

    name: str
    description: str
    fields: tuple[tuple[str, object], ...]
    offsets_from_machine: bool
    follow_operating_point: bool

    def value(self, field_name: str, default=None):
        """The preset's value of an :class:`EKFConfig` field (``default`` when it leaves it to
        :meth:`EKFConfig.recommended`)."""
        return dict(self.fields).get(field_name, default)


PRESETS: tuple[Preset, ...] = (
    Preset(
        "machine",
        "a real machine: probe offsets (machine file's [probes] prior or the baseline), the complex "
        "unbalance and both bearings' viscosity factors estimated, the bearing table that follows speed and "
        "oil temperature; an estimate the filter finds inconsistent does not act on its own",
        (("unbalance_prior_std", 2.0), ("viscosity_factor_prior_std", 0.1)),
        offsets_from_machine=True,
        follow_operating_point=True,
    ),
    Preset(
        "paper",
        "the paper's calibrated filter: unbalance, film and probe offsets known, the flowrate grid at one "
        "speed, the filter's own estimate throughout (the paper's scenarios, report and study)",
        (("model_mismatch_action", False),),
        offsets_from_machine=False,
        follow_operating_point=False,
    ),
)
"""The named configurations (:meth:`EKFConfig.preset`); the first is the default."""
DEFAULT_PRESET = PRESETS[0].name  # EKFConfig.preset's default name
PRESET_NAMES = tuple(p.name for p in PRESETS)


def preset_named(name: str) -> Preset:
    """The preset called ``name`` (one-line InputError naming the choices otherwise)."""
    for preset in PRESETS:
        if preset.name == name:
            return preset
    raise InputError(f"preset must be one of {', '.join(PRESET_NAMES)}, got {name!r}")
