"""The augmented-state Extended Kalman Filter that estimates the two oil supply flowrates (paper Eqs. 17-24).

Augmented state ``x = [s; q / q_nominal; o; f; u]``: the model's dynamic states ``s`` (SI), the two flowrates
each as a fraction of its bearing's own nominal flowrate (``q_i / q_nominal_i``) and, when their prior std is
> 0, the four probe zero offsets ``o`` [m] (random walks; each probe reads ``Rot H s + o``, Rot the probes'
mounting angle, ``probe_angle_deg``), the two bearings' viscosity factors ``f`` (random walks around 1;
``viscosity_factor_prior_std``) and the complex unbalance ``u``.

Operating point: :meth:`OilFlowEKF.step` takes the measured speed and oil temperature of the sample (and a
keyphasor angle when there is one) and hands them to a model that follows them (``set_operating_point``,
:class:`oilwatch.models.system.operating_model.OperatingAugmentedModel`) before predicting to the sample: the
plant holds them over the period that ends at the sample, and so does the prediction.
The model works in m^3/s, where a flowrate of 1e-5 and a process-noise std
of 1.7e-9 sit beside displacements of 1e-5 m; in fractions of nominal the flowrate entries of P are
O(1e-4..1e-1), which keeps the flowrate block of P and its Jacobian columns well scaled. Everything at the
interface is SI.

Per step (:meth:`OilFlowEKF.step`): predict with the model (Eqs. 19-21, skipped on the very first sample),
then update with the measured displacements (Eqs. 22-24, Joseph form, Cholesky solve; see
:mod:`oilwatch.estimator.kernels`).

* Probe faults (:mod:`oilwatch.estimator.channels`): every channel is screened and gated on its own; the
update uses
  every channel that passed (a NaN on one probe drops that channel, not the update). A probe that is dead,
  stuck, out of its physical range or persistently rejected alone is flagged (``probe_status``) and excluded
  until it has looked healthy for ``PROBE_RECOVER_S``. Nothing is ever forced through the gate.
* Differentiated velocities (eight-channel modes) use a channel's two consecutive accepted samples.
* Change detection and adaptive process noise: a fading-memory mean of each channel's standardized
  innovation (time constant ``CHANGE_WINDOW_S``; white and N(0, a / (2 - a)) per channel under the model,
  ``a`` its weight) is tested per bearing against the chi-square(2) quantile of
  ``CHANGE_TAIL_PROBABILITY``; while it fires, that bearing's flowrate gets the extra process noise
  ``change_flowrate_std_fraction`` of nominal per step (Bar-Shalom, Li & Kirubarajan 2001, sec. 11.2: a
  process-noise level switched by an innovation test). A flowrate change shows first as a persistent mean
  innovation of its bearing's probes; the filter's std then widens at once so that it covers the lag of the
  estimate, and shrinks again with the data once the innovation is white.
* ``model_consistent``: the sum of the NIS over the last ``CONSISTENCY_WINDOW_S`` does not exceed the
  chi-square quantile ``1 - CONSISTENCY_TAIL_PROBABILITY`` of its degrees of freedom (Bar-Shalom et al.
  sec. 5.4.2, the time-average NIS test; Wilson-Hilferty approximation of the quantile). A discrepancy that
  the states can absorb (an offset that looks like a flow change) stays invisible to it; one they cannot
  (a wrong 1x orbit) shows. The alarm records whether the model was consistent when it was raised.
* Flowrate bounds: after each update, a flowrate outside its bearing's coefficient table range is projected
  onto it in the metric of P^-1 (Simon & Chia, IEEE Trans. AES 38, 2002: the minimum-variance estimate given
  that the active bound holds exactly), which also moves the correlated dynamic states; P is left unchanged, a
  conservative choice that keeps the flowrate free to leave the bound (the projected covariance would have
  zero variance there). The model is therefore never evaluated outside a bearing's table.
* ``converged``: both flowrate stds below ``CONVERGED_STD_FRACTION`` of nominal, both estimates changed by
  less than ``CONVERGED_DRIFT_FRACTION`` of nominal over the last ``CONVERGED_WINDOW_S``, and some channel
  updated the filter within that window.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from oilwatch.models.system.operating_kernels import RECENTRE
from oilwatch.models.validation import InputError

from . import channels
from .alarm import StarvationAlarm
from .baseline_change import (
    CHANGE_STATUS,
    CONSISTENT,
    MISMATCH_BASELINE,
    new_change_array,
    reference_applies,
    reset_change,
)
from .ekf_config import (
    CONSISTENCY_WINDOW_S,
    CONVERGED_WINDOW_S,
    INITIAL_DISPLACEMENT_STD_M,
    INITIAL_VELOCITY_STD_M_S,
    UNBALANCE_RANDOM_WALK_SQRT_S,
    EKFConfig,
)
from .ekf_setup import (
    StateLayout,
    channel_settings,
    check_model,
    physical_covariance,
    process_noise,
    step_settings,
    summary_settings,
)
from .filter_arrays import FilterArrays
from .measurement import displacement_channels, probe_rotation, velocity_channels
from .model import AugmentedModel
from .nuisance_start import InformationFloor, ShadowJacobian, restart_parameters, settling_steps
from .reports import EstimateTrace, ReportView, StepReport
from .runout import RunoutCompensation
from .step_kernel import (
    COUNT_SINCE_UPDATE,
    COUNT_STEP,
    DECLINED,
    REPORT_CHANGING,
    REPORT_CONSISTENT,
    REPORT_CONVERGED,
    REPORT_FILTER_FLOWRATE,
    REPORT_FILTER_STD,
    REPORT_FLOWRATE,
    REPORT_MISMATCH,
    REPORT_NIS,
    REPORT_OFFSET,
    REPORT_OFFSET_STD,
    REPORT_OK,
    REPORT_ROWS,
    REPORT_SIZE,
    REPORT_STARVED,
    REPORT_STARVED_CONSISTENT,
    REPORT_STATUS,
    REPORT_STD,
    REPORT_UNBALANCE,
    REPORT_UNBALANCE_STD,
    REPORT_VISCOSITY,
    REPORT_VISCOSITY_STD,
    SUMMARY_STD_FLOOR,
    ekf_step,
    grid_batch,
    operating_step,
)

VISCOSITY_FACTOR_RANGE = (0.7, 1.4)
"""The viscosity factors' estimates are kept within this range, and the model never sees one outside it:
an oil within its ISO viscosity grade (+-10 %), a supply temperature measured within a few degC (about 3 %
per degC for turbine oils) and ageing stay well inside it. A factor that runs further is the filter reading
a model error (the 1x orbit of another unbalance distribution, runout) as film, which the model-mismatch
status is for; unbounded, it left the bearing tables (a factor of 0.26 or 1.63)."""
_PUBLISHED = (REPORT_FLOWRATE, REPORT_FLOWRATE + 1, REPORT_STD, REPORT_STD + 1, REPORT_MISMATCH)
"""The report entries a model mismatch publishes in place of the filter's (saved with the state)."""


def sub_state(state: dict[str, np.ndarray], prefix: str) -> dict[str, np.ndarray]:
    """The entries of the state dict ``state`` whose keys start with ``prefix``, the prefix removed: the
    operating model's part of a filter's state (``model_``), a start's part of a start bank's."""
    return {key.removeprefix(prefix): value for key, value in state.items() if key.startswith(prefix)}


def _checked(state: dict[str, np.ndarray], key: str, shape: tuple[int, ...]) -> np.ndarray:
    if key not in state:
        raise InputError(f"EKF state lacks {key!r}")
    value = np.asarray(state[key])
    if value.shape != shape:
        raise InputError(f"EKF state {key!r} must have shape {shape}, got {value.shape}")
    return value


class OilFlowEKF:
    """Augmented-state EKF estimating (q1, q2) from the four measured bearing displacements.

    Parameters
    ----------
    model : any :class:`oilwatch.estimator.model.AugmentedModel`.
    config : :class:`oilwatch.estimator.ekf_config.EKFConfig` (paper defaults; what it leaves open, e.g. the
    nominal
        flowrate, comes from the model: :meth:`EKFConfig.for_model`).

    ``state_layout`` (:class:`oilwatch.estimator.ekf_setup.StateLayout`) tells where each part sits in the
    state vector ``x`` of :meth:`get_state` (each flowrate in fractions of its bearing's nominal,
    ``config.q_nominal_pair()``).

    One class: its state is set in :meth:`__init__` (the configuration's fixed arrays, from
    :mod:`oilwatch.estimator.ekf_setup`) and :meth:`reset` (the arrays a run advances, handed to the compiled
    step as one :class:`oilwatch.estimator.filter_arrays.FilterArrays`), and every method here reads it.
    Records go through :meth:`run` and :meth:`run_batch`, which give exactly what as many :meth:`step`
    calls give (on a grid model at one speed with no operating point given a whole block is one compiled
    call, :func:`oilwatch.estimator.step_kernel.grid_batch`). The model's prediction calls the transition
    the nuisance states need (``transition``, ``transition_with_unbalance`` or ``transition_full``) and puts
    their Jacobian columns in place; the measured operating point goes to a model that follows it before the
    prediction to the sample (a model at one speed accepts only that speed). On the operating model
    (``compiled_transition``) a predicted sample is one compiled call,
    :func:`oilwatch.estimator.step_kernel.operating_step`, with the same digits; Python only re-centres.
    """

    def __init__(self, model: AugmentedModel, config: EKFConfig | None = None) -> None:
        self.model = model
        self.config = (config if config is not None else EKFConfig()).for_model(model)
        check_model(model, self.config)
        cfg = self.config
        layout = StateLayout.for_config(model, cfg)
        self.state_layout = layout
        n = layout.n
        self._n = n
        self._n_offsets, self._n_viscosity, self._n_unbalance = (
            layout.n_offsets,
            layout.n_viscosity,
            layout.n_unbalance,
        )
        self._offsets, self._viscosity, self._unbalance = layout.offsets, layout.viscosity, layout.unbalance
        self._size = layout.size
        self._n_trailing = layout.n_trailing
        self._trailing_jacobian = np.zeros((n, self._n_trailing))
        self._follows = callable(getattr(model, "set_operating_point", None))
        self._q_nominal = np.array(cfg.q_nominal_pair())  # each bearing's flowrate unit
        self._bounds = np.array(model.bearing_flowrate_bounds_m3_s, dtype=float)
        bounds_scaled = self._bounds / self._q_nominal[:, None]
        self._dt = float(model.dt_s)
        self._first_step = round(cfg.first_sample_time_s / self._dt)
        if abs(self._first_step * self._dt - cfg.first_sample_time_s) > 1e-6 * self._dt:
            raise InputError(
                f"EKFConfig.first_sample_time_s must be a multiple of the model's dt = {self._dt:g} s, "
                f"got {cfg.first_sample_time_s:g} s"
            )

        angle = math.radians(cfg.probe_angle_deg)
        pad = np.zeros((4, self._n_trailing))
        obs4, self._noise4 = displacement_channels(model, cfg.noise_std_m, angle, self._n_offsets)
        # slow-roll runout compensation (estimator/runout.py): its residual uncertainty adds to R
        self._runout = RunoutCompensation.for_model(cfg.runout, model, cfg.first_sample_time_s)
        angle_of = getattr(model, "rotor_angle_rad", None)
        self._rotor_angle_of = angle_of if callable(angle_of) else None
        self._noise4 = self._noise4 + self._runout.residual_covariance_m2()
        self._obs4 = np.hstack([obs4, pad])
        channels8 = velocity_channels(model, cfg.noise_std_m, cfg.velocity_noise, angle, self._n_offsets)
        if channels8 is not None:
            channels8 = (np.hstack([channels8[0], np.vstack([pad, pad])]), channels8[1])
        # displacement-only: empty eight-channel arrays tell the compiled step to use four channels
        self._obs8, self._noise8 = (
            channels8 if channels8 is not None else (np.zeros((0, self._size)), np.zeros((0, 0)))
        )
        self._channel_settings = channel_settings(cfg, model, self._dt)
        self._q_var = (cfg.flowrate_process_std_m3_s / self._q_nominal) ** 2
        self._settings = step_settings(cfg, self._dt, bounds_scaled, self._q_var)
        self._consistency_steps = max(1, round(CONSISTENCY_WINDOW_S / self._dt))
        unbalance_walk = UNBALANCE_RANDOM_WALK_SQRT_S**2 * self._dt
        self._summary_settings = summary_settings(cfg, self._q_nominal, self._bounds, unbalance_walk)
        self._report = np.zeros(REPORT_SIZE)
        self._batch_table = np.empty((0, REPORT_SIZE))
        self._one_row = np.empty((1, REPORT_SIZE))
        # a grid model at one speed with no nuisance in its transition: whole batches in one compiled call
        batch = getattr(model, "batch_transition", None)
        plain = not (
            self._follows or self._n_unbalance or self._n_viscosity or self._runout.vectors is not None
        )
        # the operating model: a predicted sample's transitions and update in one compiled call
        compiled = getattr(model, "compiled_transition", None)
        self._operating_step = compiled() if callable(compiled) else None
        self._factor_range = np.array(VISCOSITY_FACTOR_RANGE)
        self._no_shadow = np.zeros(0)
        self._predicted = np.zeros(n)  # the estimate's next state beside the shadow's
        self._batch_next, self._batch_exogenous = np.zeros(n), np.zeros(3)
        self._batch_transition, self._batch_flow_jacobian = np.zeros((n, n)), np.zeros((n, 2))
        self._counters = layout.counters()
        self._process_noise = process_noise(model, cfg, layout, self._dt, self._q_var, unbalance_walk)

        self._jacobian = np.zeros((self._size, self._size))
        self._work = np.zeros((self._size, self._size))
        self._z8 = np.zeros(8)
        self._accepted = np.zeros(4, dtype=bool)
        self._window = max(1, round(CONVERGED_WINDOW_S / self._dt))
        self.alarm = StarvationAlarm(cfg.alarm, self._dt, self._q_nominal)
        self._change = new_change_array(cfg, model, self._dt, probe_rotation(angle))
        # shadow Jacobian and settling start while the flowrates are estimated beside viscosity factors
        # that no baseline primed: the nearly unobservable direction (estimator/nuisance_start.py)
        baseline = cfg.offset_baseline
        free = self._n_viscosity > 0 and (baseline is None or baseline.viscosity_factor is None)
        free = free and cfg.flowrate_process_std_m3_s > 0.0  # a baseline's run holds the flowrates
        constants = cfg.nuisance_settling_time_constants if free else 0.0
        if constants and callable(getattr(model, "reset_operating_state", None)):
            model.reset_operating_state()  # the least damped mode at the model's reference point
        self._settling = settling_steps(model, cfg.q_initial_pair(), constants)
        self._no_flow_jacobian = np.zeros((n, 2))
        # the first sample's unused transition Jacobian: C-contiguous like the model's, so that the compiled
        # step has one signature (a strided view of the work array compiled it a second time)
        self._no_state_jacobian = np.zeros((n, n))
        self._shadow = ShadowJacobian(n, self._n_trailing) if free and cfg.nuisance_shadow else None
        floor = cfg.nuisance_information_floor and getattr(model, "maps", None) is not None
        floor = floor and cfg.flowrate_process_std_m3_s > 0.0
        runout = cfg.runout is not None and any(cfg.runout.once_std_m)
        bound = floor and self._shadow is not None
        # the considered errors' term alone (a baseline, or the grid model): the slow-roll fit's residual
        # and the probes' scale factors
        consider = floor and (runout or cfg.probe_scale_factor_std > 0.0)
        self._floor = (
            InformationFloor(model, cfg, n, self._n_offsets, self._n_unbalance, bound=bound)
            if bound or consider
            else None
        )
        # (the compiled batch has no floor: only without one)
        self._grid_batch = batch() if callable(batch) and plain and self._floor is None else None
        self.reset()

    def reset(self) -> None:
        """Return to the initial estimate and covariance of the configuration (step 0)."""
        cfg = self.config
        n = self._n
        q0 = np.array(cfg.q_initial_pair())
        self._x = np.zeros(self._size)
        if cfg.initial_state == "static":
            self._x[:n] = self.model.static_state(q0)
        self._x[n : n + 2] = q0 / self._q_nominal
        self._P = np.zeros((self._size, self._size))
        self._P[:n, :n] = physical_covariance(
            self.model, n, INITIAL_DISPLACEMENT_STD_M, INITIAL_VELOCITY_STD_M_S
        )
        self._P[n : n + 2, n : n + 2] = np.diag(
            (np.array(cfg.initial_flowrate_std_pair()) / self._q_nominal) ** 2
        )
        baseline = cfg.offset_baseline
        if baseline is not None:
            self._x[self._offsets] = baseline.offsets_m
            self._P[self._offsets, self._offsets] = np.diag(np.square(baseline.offset_prior_std_m()))
        elif self._n_offsets:
            self._P[self._offsets, self._offsets] = cfg.offset_prior_std_m**2 * np.eye(self._n_offsets)
        # the nuisances a commissioning baseline estimated are its prior; the configured one otherwise
        viscosity_std = cfg.viscosity_factor_prior_std
        for count, part, name, mean, std in (
            (self._n_unbalance, self._unbalance, "unbalance", (1.0, 0.0), cfg.unbalance_prior_std),
            (self._n_viscosity, self._viscosity, "viscosity_factor", (1.0, 1.0), viscosity_std),
        ):
            if not count:
                continue
            known = None if baseline is None else getattr(baseline, name)
            self._x[part] = mean if known is None else known
            variance = std**2 * np.ones(2) if known is None else np.square(getattr(baseline, f"{name}_std"))
            self._P[part, part] = np.diag(variance)
        joint = None
        if baseline is not None:
            joint = baseline.prior_covariance(self._n_viscosity > 0, self._n_unbalance > 0)
        if joint is not None:  # the baseline's correlations (offsets, factors, unbalance: contiguous states)
            self._P[n + 2 :, n + 2 :] = joint
        if callable(getattr(self.model, "reset_operating_state", None)):
            self.model.reset_operating_state()
        self._health, self._health_values = channels.new_health()
        self._operating = (getattr(self.model, "speed_hz", None), None)
        self._counters[COUNT_STEP] = self._counters[COUNT_SINCE_UPDATE] = 0
        self._history = np.zeros((self._window, 2))
        self._nis_window = np.zeros((self._consistency_steps, 2))  # NIS and rows of each step
        self._nis_sums = np.zeros(2)
        self._changing = np.zeros(2, dtype=bool)
        self._process_noise[n : n + 2, n : n + 2] = np.diag(self._q_var)
        self._summary_settings[SUMMARY_STD_FLOOR : SUMMARY_STD_FLOOR + 2] = 0.0  # the alarm's std floor
        self.alarm.clear()
        reset_change(self._change)
        self._set_last(0.0, 0, False, False, True)
        # the compiled step's arrays (estimator.filter_arrays), renewed with the ones a reset replaces
        self._arrays = FilterArrays(
            self._x,
            self._P,
            self._trailing_jacobian,
            self._process_noise,
            self._jacobian,
            self._work,
            self._z8,
            self._obs4,
            self._noise4,
            self._obs8,
            self._noise8,
            self._settings,
            self._health,
            self._health_values,
            self._channel_settings,
            self._accepted,
            self._changing,
            self._counters,
            self._nis_window,
            self._nis_sums,
            self._history,
            self._summary_settings,
            self.alarm.record,
            self.alarm.settings,
            self._report,
            self._change,
        )
        self._packed = tuple(self._arrays)
        self._prior = (self._x.copy(), self._P.copy())
        if self._shadow is not None:
            self._shadow.reset()
        if self._floor is not None:
            self._floor.reset()

    def step(
        self,
        displacement_m: np.ndarray,
        speed_hz: float | None = None,
        oil_temperature_c: float | None = None,
        rotor_angle_rad: float | None = None,
    ) -> StepReport:
        """Process one sample of the measured displacements (x1, y1, x2, y2) [m], shape (4,).

        The sample belongs to time ``first_sample_time_s + k dt`` with k = :attr:`step_count`; the prediction
        from the previous sample runs first. A non-finite entry drops that channel from this sample.
        ``speed_hz`` [Hz] and ``oil_temperature_c`` [degC], measured over the period that ends at the sample
        (None: unchanged), and the keyphasor's ``rotor_angle_rad`` at the previous sample (None: the integral
        of the speed) go to a model that follows them; a model that does not accepts only its own speed.
        """
        step = int(self._counters[COUNT_STEP])
        self._advance(displacement_m, speed_hz, oil_temperature_c, rotor_angle_rad)
        return self._step_report(step)

    def _advance(
        self,
        displacement_m: np.ndarray,
        speed_hz: float | None,
        oil_temperature_c: float | None,
        rotor_angle_rad: float | None,
    ) -> None:
        """:meth:`step` without its report: everything lands in ``self._report`` (a grid model at one speed
        with no operating point given: the compiled batch of one sample, no Python between model and
        filter)."""
        displacement = np.ascontiguousarray(displacement_m, dtype=np.float64)
        if displacement.shape != (4,):
            raise InputError(f"displacement_m must have shape (4,), got {displacement.shape}")
        if speed_hz is not None or oil_temperature_c is not None or rotor_angle_rad is not None:
            self._set_operating_point(speed_hz, oil_temperature_c, rotor_angle_rad)
            reference_applies(self._change, self.config.offset_baseline, *self._operating)
        if self._grid_batch is not None and speed_hz is None and oil_temperature_c is None:
            self._run_grid_batch(displacement.reshape(1, 4), self._one_row)
            return
        step = int(self._counters[COUNT_STEP])
        if self._runout.vectors is not None:
            # the runout at this sample's rotor angle: the model's (integral of the measured speed, anchored
            # at the keyphasor) when it follows the operating point, else the nominal speed's
            angle_of = self._rotor_angle_of
            angle = angle_of(self._first_step + step) if angle_of is not None else None
            displacement = self._runout.compensate(displacement, step, angle)
        if not (step > 0 and self._compiled_prediction(displacement, step)):
            self._predict_and_update(displacement, step)
        if step == self._settling and step > 0:
            restart_parameters(self._x, self._P, *self._prior, self._n)
            if self._floor is not None:
                self._floor.reset()
            self._refresh_report()
        elif self._floor is not None and step > self._settling:  # estimator/nuisance_start.py
            if self._floor.due():
                unbalance = self.unbalance if self._n_unbalance else (1.0, 0.0)
                self._floor.begin(self._flowrate_si(), self.viscosity_factor, unbalance)
            self._floor.work()  # one stage of an update under way
            # the floor is the filter's: not where the static change since the baseline is published, whose
            # std carries its own model error (estimator.baseline_change)
            if self._report[REPORT_MISMATCH] != MISMATCH_BASELINE:
                reported = self._report[REPORT_STD : REPORT_STD + 2]
                reported[:] = self._floor.published_std(reported)
        if self._floor is not None and step >= self._settling:  # the alarm's floor from the next step
            self._summary_settings[SUMMARY_STD_FLOOR : SUMMARY_STD_FLOOR + 2] = self._alarm_std_floor()

    def _alarm_std_floor(self) -> np.ndarray:
        """(2,) the std the alarm judges at least: the bound with the consider term where the floor holds the
        bound, else the published std (the filter's and the consider term in quadrature)."""
        return self._floor.std if self._floor.bound else self._report[REPORT_STD : REPORT_STD + 2]

    def _compiled_prediction(self, displacement: np.ndarray, step: int) -> bool:
        """The prediction to sample ``step`` (> 0) and its update as one compiled call on the operating model
        (:func:`oilwatch.estimator.step_kernel.operating_step`), re-centring the model when it asks to; False
        (nothing done) on another model or a sample the Python path must take."""
        if self._operating_step is None:
            return False
        arrays, exogenous, limits = self._operating_step
        model_step = self._first_step + step - 1
        phase = self.model.transition_phase(model_step)
        shadow, shadow_state = self._shadow, self._no_shadow
        if shadow is not None:
            if shadow.state is None:
                shadow.state = self._x[: self._n].copy()
            shadow_state = shadow.state
        while True:
            answer = operating_step(
                arrays, exogenous, limits, phase, model_step, self._factor_range, shadow_state,
                self._predicted, step <= self._settling, self._no_flow_jacobian, displacement, self._packed,
            )  # fmt: skip
            if answer != RECENTRE:
                return answer != DECLINED
            self.model.recentre_due(model_step)

    def _predict_and_update(self, displacement: np.ndarray, step: int) -> None:
        """The prediction to sample ``step`` with the model's Python entries (none at the first sample), then
        the compiled update (:func:`oilwatch.estimator.step_kernel.ekf_step`)."""
        predict = step > 0
        if predict:
            model_step = self._first_step + step - 1
            if self._shadow is not None:
                shadow = self._shadow.jacobians(
                    self._predict_with_model, self._x[: self._n], self._trailing_jacobian, model_step
                )
            next_state, state_jac, flow_jac = self._predict_with_model(model_step)
            if step <= self._settling:  # settling start: the parameters out of the Jacobian
                flow_jac = self._no_flow_jacobian
                self._trailing_jacobian[:] = 0.0
            elif self._shadow is not None:
                flow_jac = shadow[0]
                self._trailing_jacobian[:] = shadow[1]
            next_state = np.ascontiguousarray(next_state, dtype=np.float64)
            state_jac = np.ascontiguousarray(state_jac, dtype=np.float64)
            flow_jac = np.ascontiguousarray(flow_jac, dtype=np.float64)
        else:
            n = self._n
            next_state, state_jac, flow_jac = self._x[:n], self._no_state_jacobian, self._no_flow_jacobian
        ekf_step(predict, next_state, state_jac, flow_jac, displacement, self._packed)
        if self._n_viscosity:  # P left unchanged, as at the flowrates' bounds
            factors = self._x[self._viscosity]
            np.clip(factors, *VISCOSITY_FACTOR_RANGE, out=factors)

    def get_state(self) -> dict[str, np.ndarray]:
        """The complete filter state as copies of numpy arrays (restoring it continues bit-identically, so
        that an FMU can save and restore it).

        The state is a flat ``dict[str, numpy.ndarray]`` (scalars as 0-d arrays), every array a copy:

        ================  ========  =====================================================================
        key               shape     meaning
        ================  ========  =====================================================================
        x                 (N,)      [s; q / q_nominal; offsets, viscosity factors, unbalance if estimated]
        P                 (N, N)    its covariance
        health            (4, 6)    int: probe records (:mod:`oilwatch.estimator.channels`)
        health_values     (4, 4)    float: last reading, innovation power and mean, last accepted reading
        step              ()        int: samples processed
        since_update      ()        int: samples since the last update that used a channel
        q_history         (W, 2)    ring buffer of q / q_nominal for the convergence drift test
        nis_window        (C, 2)    ring buffer of NIS and rows for the consistency test
        nis_sums          (2,)      their running sums
        process_noise_q   (2,)      the flowrate process variances of the next prediction (change test)
        changing          (2,)      bool: change test firing per bearing
        last              (5,)      float: nis, n_measurements, measurement_ok, converged, model_consistent
        alarm_*           (2,)      the alarm flags and hold counters (see :mod:`oilwatch.estimator.alarm`)
        operating         (4,)      (given?, speed [Hz], given?, oil temperature [degC]) last measured
        model_mismatch    (M,)      the mismatch status and static means (estimator.baseline_change)
        published         (5,)      the published flowrates and stds, and the mismatch status
        model_*           ...       a model's operating state, when it follows the operating point
        ================  ========  =====================================================================
        """
        state = self._export_state()
        if self._shadow is not None and self._shadow.state is not None:
            state["nuisance_shadow"] = self._shadow.state.copy()
        if self._floor is not None:
            state["nuisance_floor"] = self._floor.get_state()
        return state

    def set_state(self, state: dict[str, np.ndarray]) -> None:
        """Restore a state from :meth:`get_state` exactly (same model and configuration)."""
        self._import_state(state)
        if self._shadow is not None:
            shadow = state.get("nuisance_shadow")
            self._shadow.state = None if shadow is None else np.array(shadow, dtype=float)
        if self._floor is not None and "nuisance_floor" in state:
            self._floor.set_state(state["nuisance_floor"])
            applied = int(self._counters[COUNT_STEP]) > self._settling
            floor = self._alarm_std_floor() if applied else 0.0
            self._summary_settings[SUMMARY_STD_FLOOR : SUMMARY_STD_FLOOR + 2] = floor

    def with_model_centre_of(
        self, state: dict[str, np.ndarray], later: dict[str, np.ndarray]
    ) -> dict[str, np.ndarray]:
        """``state`` (:meth:`get_state`) with its operating model's correction centre taken from ``later``, a
        later state of this filter (``OperatingAugmentedModel.with_centre_of``; a model without one:
        ``state``)."""
        merge = getattr(self.model, "with_centre_of", None)
        if merge is None or "model_centre" not in later:
            return state
        merged = merge(sub_state(state, "model_"), sub_state(later, "model_"))
        return {**state, **{f"model_{key}": value for key, value in merged.items()}}

    @property
    def flowrate_m3_s(self) -> np.ndarray:
        """(2,) current flowrate estimates [m^3/s], each inside its bearing's table range."""
        return np.array(self._flowrate_si())

    def _flowrate_si(self) -> tuple[float, float]:
        # clipped in SI as well: the round trip through the scaled unit may leave a bound by one ulp
        n, (scale1, scale2) = self._n, self._q_nominal.tolist()
        (low1, high1), (low2, high2) = self._bounds.tolist()
        return (
            min(max(float(self._x[n]) * scale1, low1), high1),
            min(max(float(self._x[n + 1]) * scale2, low2), high2),
        )

    @property
    def flowrate_std_m3_s(self) -> np.ndarray:
        """(2,) standard deviations of the flowrate estimates from P [m^3/s]."""
        n = self._n
        return np.sqrt(np.diag(self._P)[n : n + 2]) * self._q_nominal

    def _nuisance(self, block: slice, known: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
        """(estimate, std) copies of a nuisance block of the state; (the known value, zeros) when the block
        is not estimated (an empty slice)."""
        if block.stop > block.start:
            return self._x[block].copy(), np.sqrt(np.diag(self._P)[block])
        return np.array(known, dtype=float), np.zeros(len(known))

    @property
    def offset_m(self) -> np.ndarray:
        """(4,) estimated probe zero offsets [m] (zeros when the offsets are not estimated)."""
        return self._nuisance(self._offsets, (0.0,) * 4)[0]

    @property
    def offset_std_m(self) -> np.ndarray:
        """(4,) their stds [m] (zeros when the offsets are not estimated)."""
        return self._nuisance(self._offsets, (0.0,) * 4)[1]

    @property
    def unbalance(self) -> np.ndarray:
        """(2,) the estimated unbalance (real, imaginary) relative to the machine file's ((1, 0) if fixed)."""
        return self._nuisance(self._unbalance, (1.0, 0.0))[0]

    @property
    def unbalance_std(self) -> np.ndarray:
        """(2,) its stds (zeros when the unbalance is not estimated)."""
        return self._nuisance(self._unbalance, (1.0, 0.0))[1]

    @property
    def viscosity_factor(self) -> np.ndarray:
        """(2,) each bearing's estimated viscosity factor (film over the oil law's; ones if not estimated)."""
        return self._nuisance(self._viscosity, (1.0, 1.0))[0]

    @property
    def viscosity_factor_std(self) -> np.ndarray:
        """(2,) their stds (zeros when the factors are not estimated)."""
        return self._nuisance(self._viscosity, (1.0, 1.0))[1]

    @property
    def dynamic_state(self) -> np.ndarray:
        """(n,) copy of the dynamic-state estimate s [SI]."""
        return self._x[: self._n].copy()

    @property
    def covariance(self) -> np.ndarray:
        """(N, N) copy of P, N = n + 2 (+ 4 with offset states); the flowrate block is in the internal unit
        (fractions of nominal)^2, the offsets' in m^2."""
        return self._P.copy()

    @property
    def step_count(self) -> int:
        """Number of samples processed."""
        return int(self._counters[COUNT_STEP])

    @property
    def settling_steps(self) -> int:
        """Samples of the settling start (:mod:`oilwatch.estimator.nuisance_start`; 0: none): the flowrates
        and nuisances restart from their prior after this sample."""
        return self._settling

    def current_report(self) -> StepReport:
        """The report of the last processed sample, rebuilt from the state (e.g. after :meth:`set_state`)."""
        self._refresh_report()
        return self._step_report(self.step_count - 1)

    def _step_report(self, step: int) -> StepReport:
        """The report of sample ``step``, on a copy of the report array (independent of the filter)."""
        return ReportView(step, self._report.copy())

    def _refresh_report(self) -> None:
        """The report array from the state as it is (after a reset or a restored state): the flowrates the
        next prediction starts from, the nuisances and the flags :meth:`current_report` reads."""
        report = self._report
        report[REPORT_FILTER_FLOWRATE : REPORT_FILTER_FLOWRATE + 2] = self._flowrate_si()
        report[REPORT_FILTER_STD : REPORT_FILTER_STD + 2] = self.flowrate_std_m3_s
        status = self._change[CHANGE_STATUS]
        report[REPORT_MISMATCH] = status
        if status == CONSISTENT:  # else the published values stay (a restored state brings them)
            report[REPORT_FLOWRATE : REPORT_FLOWRATE + 2] = self._flowrate_si()
            report[REPORT_STD : REPORT_STD + 2] = self.flowrate_std_m3_s
        report[REPORT_VISCOSITY : REPORT_VISCOSITY + 2] = self.viscosity_factor
        report[REPORT_VISCOSITY_STD : REPORT_VISCOSITY_STD + 2] = self.viscosity_factor_std
        report[REPORT_OFFSET : REPORT_OFFSET + 4] = self.offset_m
        report[REPORT_OFFSET_STD : REPORT_OFFSET_STD + 4] = self.offset_std_m
        report[REPORT_UNBALANCE : REPORT_UNBALANCE + 2] = self.unbalance
        report[REPORT_UNBALANCE_STD : REPORT_UNBALANCE_STD + 2] = self.unbalance_std
        report[REPORT_STARVED : REPORT_STARVED + 2] = self.alarm.starved
        report[REPORT_STARVED_CONSISTENT : REPORT_STARVED_CONSISTENT + 2] = self.alarm.starved_consistent
        report[REPORT_CHANGING : REPORT_CHANGING + 2] = self._changing
        report[REPORT_STATUS : REPORT_STATUS + 4] = self._health[:, channels.STATUS]

    def _set_last(self, nis: float, rows: int, ok: bool, converged: bool, consistent: bool) -> None:
        """The last sample's scalars (a reset, a restored state) and the rest of the report from the state."""
        report = self._report
        report[REPORT_NIS], report[REPORT_ROWS], report[REPORT_OK] = nis, rows, ok
        report[REPORT_CONVERGED], report[REPORT_CONSISTENT] = converged, consistent
        self._refresh_report()

    @property
    def _last(self) -> tuple[float, int, bool, bool, bool]:
        """(nis, n_measurements, measurement_ok, converged, model_consistent) of the last sample."""
        report = self._report
        return (
            float(report[REPORT_NIS]),
            int(report[REPORT_ROWS]),
            bool(report[REPORT_OK]),
            bool(report[REPORT_CONVERGED]),
            bool(report[REPORT_CONSISTENT]),
        )

    def run(
        self,
        displacements_m: np.ndarray,
        progress: Callable[[int, int], None] | None = None,
        speed_hz: np.ndarray | None = None,
        oil_temperature_c: np.ndarray | None = None,
    ) -> EstimateTrace:
        """Process a record of K samples (K, 4) [m] as K :meth:`step` calls; return the per-step outputs.

        ``speed_hz`` and ``oil_temperature_c`` (K,), when given, are each sample's measured operating point
        (see :meth:`step`). ``progress(done, total)`` is called every 100 samples and at the end."""
        record, operating = self._batch_inputs(displacements_m, speed_hz, oil_temperature_c)
        count = record.shape[0]
        trace = EstimateTrace.empty(count)
        table = np.empty((count, REPORT_SIZE))
        for start in range(0, count, 100):
            if progress is not None:
                progress(start, count)
            stop = min(start + 100, count)
            self._advance_rows(record, operating, start, stop, table)
        if progress is not None:
            progress(count, count)
        trace.fill(table, count)
        return trace

    def run_batch(
        self,
        displacements_m: np.ndarray,
        speed_hz: np.ndarray | None = None,
        oil_temperature_c: np.ndarray | None = None,
        out: EstimateTrace | None = None,
    ) -> EstimateTrace:
        """K samples (K, 4) [m] on from the filter's current state, bit-identical to K :meth:`step` calls,
        without a StepReport per sample: the batch entry of ``oilwatch estimate``.

        ``speed_hz`` [Hz] and ``oil_temperature_c`` [degC] (K,) as in :meth:`step`; a NaN entry means not
        given for that sample (the model keeps the last value). ``out``: a trace of at least K rows whose
        first K rows are filled and which is returned (no allocation per block); else a new trace."""
        record, operating = self._batch_inputs(displacements_m, speed_hz, oil_temperature_c, missing=True)
        count = record.shape[0]
        if out is None:
            out = EstimateTrace.empty(count)
        elif out.q_m3_s.shape[0] < count:
            raise InputError(f"out must have at least {count} rows, got {out.q_m3_s.shape[0]}")
        table = self._batch_table
        if table.shape[0] < count:
            table = self._batch_table = np.empty((count, REPORT_SIZE))
        self._advance_rows(record, operating, 0, count, table)
        out.fill(table, count)
        return out

    def grid_batch_arguments(self) -> tuple | None:
        """The arguments of :func:`oilwatch.estimator.step_kernel.grid_batch` that belong to this filter, in
        its order less the record and the report table: ``(transition, forcing, axes, omega, dt, first_step,
        next, transition_work, flow_jacobian, exogenous, packed)``; None unless the filter steps as one
        compiled call (a grid model at one speed). The arrays are the filter's own storage: a compiled
        caller that runs ``grid_batch`` on them (the estimator FMU's plain step,
        :mod:`oilwatch.fmu_src.ekf_plain_step`) advances the filter exactly as :meth:`step` does. They stay
        valid through :meth:`set_state` (which copies into them) and are replaced by ``reset``."""
        if self._grid_batch is None:
            return None
        return (
            *self._grid_batch,
            self._first_step,
            self._batch_next,
            self._batch_transition,
            self._batch_flow_jacobian,
            self._batch_exogenous,
            self._packed,
        )

    def _run_grid_batch(self, record: np.ndarray, table: np.ndarray) -> None:
        """:func:`oilwatch.estimator.step_kernel.grid_batch` on the record's rows (K, 4), reports into
        ``table``."""
        transition, forcing, axes, omega, dt = self._grid_batch
        grid_batch(
            transition,
            forcing,
            axes,
            omega,
            dt,
            self._first_step,
            record,
            table,
            self._batch_next,
            self._batch_transition,
            self._batch_flow_jacobian,
            self._batch_exogenous,
            self._packed,
        )

    def _batch_inputs(self, displacements_m, speed_hz, oil_temperature_c, missing: bool = False):
        """The record (K, 4) and the per-sample operating point as lists of Python floats or None (or None
        for a column not given); ``missing``: NaN entries are None."""
        record = np.asarray(displacements_m, dtype=np.float64)
        if record.ndim != 2 or record.shape[1] != 4:
            raise InputError(f"displacements_m must have shape (K, 4), got {record.shape}")
        count = record.shape[0]
        operating = []
        for name, values in (("speed_hz", speed_hz), ("oil_temperature_c", oil_temperature_c)):
            if values is not None:
                values = np.asarray(values, dtype=float)
                if values.shape != (count,):
                    raise InputError(f"{name} must have shape ({count},), got {values.shape}")
                values = values.tolist()
                if missing:
                    values = [None if v != v else v for v in values]
            operating.append(values)
        return record, operating

    def _advance_rows(self, record, operating, start: int, stop: int, table: np.ndarray) -> None:
        """Samples ``start:stop`` of the record through :meth:`_advance`, each report into ``table``'s row
        (all in one compiled call for a grid model at one speed with no operating point given)."""
        advance, report = self._advance, self._report
        speed, temperature = operating
        if speed is None and temperature is None and self._grid_batch is not None:
            self._run_grid_batch(np.ascontiguousarray(record[start:stop]), table[start:stop])
            return
        if speed is None and temperature is None:
            for k in range(start, stop):
                advance(record[k], None, None, None)
                table[k] = report
            return
        for k in range(start, stop):
            advance(
                record[k],
                None if speed is None else speed[k],
                None if temperature is None else temperature[k],
                None,
            )
            table[k] = report

    def _predict_with_model(
        self, model_step: int, state: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The model's transition from the current estimate (or from ``state`` at the current flowrates and
        nuisances) to the next sample: ``(s_next, df/ds, df/dq)``, with the nuisance columns of the Jacobian
        (viscosity factors, unbalance) put into place."""
        n = self._n
        s = self._x[:n] if state is None else state
        flowrate = self._report[REPORT_FILTER_FLOWRATE : REPORT_FILTER_FLOWRATE + 2]
        trailing = self._trailing_jacobian
        if self._n_viscosity:
            factors = np.clip(self._x[self._viscosity], *VISCOSITY_FACTOR_RANGE)
            unbalance = self._x[self._unbalance] if self._n_unbalance else None
            next_state, state_jac, flow_jac, viscosity_jac, unbalance_jac = self.model.transition_full(
                s, flowrate, model_step, factors, unbalance
            )
            trailing[:, :2] = viscosity_jac
            if self._n_unbalance:
                trailing[:, 2:] = unbalance_jac
            return next_state, state_jac, flow_jac
        if self._n_unbalance:
            next_state, state_jac, flow_jac, unbalance_jac = self.model.transition_with_unbalance(
                s, flowrate, model_step, self._x[self._unbalance]
            )
            trailing[:, :] = unbalance_jac
            return next_state, state_jac, flow_jac
        return self.model.transition(s, flowrate, model_step)

    def _set_operating_point(
        self, speed_hz: float | None, oil_temperature_c: float | None, rotor_angle_rad: float | None
    ) -> None:
        """Hand the measured operating point to the model (InputError for one it cannot follow)."""
        model = self.model
        if self._follows:
            speed, temperature = self._operating
            speed = speed if speed_hz is None else speed_hz
            temperature = temperature if oil_temperature_c is None else oil_temperature_c
            model.set_operating_point(speed, temperature, rotor_angle_rad)
            self._operating = (speed, temperature)
            return
        own = getattr(model, "speed_hz", None)
        if speed_hz is not None and own is not None and not math.isclose(speed_hz, own, rel_tol=1e-9):
            raise InputError(
                f"speed_hz = {speed_hz:g} Hz: this estimator's model holds one speed ({own:g} Hz); build "
                "it on the operating-point model to follow speed and oil temperature"
            )
        if rotor_angle_rad is not None:
            raise InputError("rotor_angle_rad needs a model that follows the operating point")

    def _export_state(self) -> dict[str, np.ndarray]:
        """The filter's state as a dict of array copies."""
        n = self._n
        state = {
            "x": self._x.copy(),
            "P": self._P.copy(),
            "health": self._health.copy(),
            "health_values": self._health_values.copy(),
            "step": np.array(self.step_count, dtype=np.int64),
            "since_update": np.array(self._counters[COUNT_SINCE_UPDATE], dtype=np.int64),
            "q_history": self._history.copy(),
            "nis_window": self._nis_window.copy(),
            "nis_sums": self._nis_sums.copy(),
            "process_noise_q": np.diag(self._process_noise)[n : n + 2].copy(),
            "changing": self._changing.copy(),
            "last": np.array([float(v) for v in self._last]),
        }
        state.update(self.alarm.get_state())
        state["model_mismatch"] = self._change.copy()
        state["published"] = self._report[list(_PUBLISHED)].copy()
        speed, temperature = self._operating
        state["operating"] = np.array(
            [float(speed is not None), speed or 0.0, float(temperature is not None), temperature or 0.0]
        )
        getter = getattr(self.model, "get_operating_state", None)
        if callable(getter):
            state.update({f"model_{key}": value for key, value in getter().items()})
        return state

    def _import_state(self, state: dict[str, np.ndarray]) -> None:
        """Restore ``state`` (from :meth:`_export_state` of a filter with the same model and config)."""
        size = self._size
        x = _checked(state, "x", (size,))
        covariance = _checked(state, "P", (size, size))
        if not (np.isfinite(x).all() and np.isfinite(covariance).all()):
            raise InputError("EKF state 'x' and 'P' must be finite")
        self._x[:] = x
        self._P[:, :] = covariance
        self._health[:, :] = _checked(state, "health", self._health.shape)
        self._health_values[:, :] = _checked(state, "health_values", self._health_values.shape)
        self._counters[COUNT_STEP] = int(_checked(state, "step", ()))
        self._counters[COUNT_SINCE_UPDATE] = int(_checked(state, "since_update", ()))
        self._history[:, :] = _checked(state, "q_history", self._history.shape)
        self._nis_window[:, :] = _checked(state, "nis_window", self._nis_window.shape)
        self._nis_sums[:] = _checked(state, "nis_sums", (2,))
        n = self._n
        noise = _checked(state, "process_noise_q", (2,))
        self._process_noise[n, n], self._process_noise[n + 1, n + 1] = float(noise[0]), float(noise[1])
        self._changing[:] = _checked(state, "changing", (2,))
        nis, rows, ok, converged, consistent = _checked(state, "last", (5,))
        self.alarm.set_state(state)
        if "model_mismatch" in state:
            self._change[:] = _checked(state, "model_mismatch", self._change.shape)
            self._report[list(_PUBLISHED)] = _checked(state, "published", (len(_PUBLISHED),))
        self._set_last(float(nis), int(rows), bool(ok), bool(converged), bool(consistent))
        if "operating" in state:
            has_speed, speed, has_temperature, temperature = (
                float(v) for v in _checked(state, "operating", (4,))
            )
            self._operating = (speed if has_speed else None, temperature if has_temperature else None)
        setter = getattr(self.model, "set_operating_state", None)
        if callable(setter):
            model_state = sub_state(state, "model_")
            if model_state:
                setter(model_state)
