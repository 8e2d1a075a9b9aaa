"""The augmented-state Extended Kalman Filter that estimates the two oil supply flowrates (paper Eqs. 17-24).

Augmented state ``x = [s; q / q_nominal; o; f; u]``: the model's dynamic states ``s`` (SI), the two flowrates
as fractions of the nominal flowrate and, when their prior std is > 0, the four probe zero offsets ``o`` [m]
(random walks; each probe reads ``Rot H s + o``, Rot the probes' mounting angle, ``probe_angle_deg``), the two
bearings' viscosity factors ``f`` (random walks around 1; ``viscosity_factor_prior_std``) and the complex
unbalance ``u``.

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
  until it has looked healthy for ``probe_recover_s``. Nothing is ever forced through the gate.
* Differentiated velocities (eight-channel modes) use a channel's two consecutive accepted samples.
* Change detection and adaptive process noise: a fading-memory mean of each channel's standardized
  innovation (time constant ``change_window_s``; white and N(0, a / (2 - a)) per channel under the model,
  ``a`` its weight) is tested per bearing against the chi-square(2) quantile of
  ``change_tail_probability``; while it fires, that bearing's flowrate gets the extra process noise
  ``change_flowrate_std_fraction`` of nominal per step (Bar-Shalom, Li & Kirubarajan 2001, sec. 11.2: a
  process-noise level switched by an innovation test). A flowrate change shows first as a persistent mean
  innovation of its bearing's probes; the filter's std then widens at once so that it covers the lag of the
  estimate, and shrinks again with the data once the innovation is white.
* ``model_consistent``: the sum of the NIS over the last ``consistency_window_s`` does not exceed the
  chi-square quantile ``1 - consistency_tail_probability`` of its degrees of freedom (Bar-Shalom et al.
  sec. 5.4.2, the time-average NIS test; Wilson-Hilferty approximation of the quantile). A discrepancy that
  the states can absorb (an offset that looks like a flow change) stays invisible to it; one they cannot
  (a wrong 1x orbit) shows. The alarm records whether the model was consistent when it was raised.
* Flowrate bounds: after each update, a flowrate outside the coefficient table's range is projected onto it in
  the metric of P^-1 (Simon & Chia, IEEE Trans. AES 38, 2002: the minimum-variance estimate given that the
  active bound holds exactly), which also moves the correlated dynamic states; P is left unchanged, a
  conservative choice that keeps the flowrate free to leave the bound (the projected covariance would have
  zero variance there). The model is therefore never evaluated outside its table.
* ``converged``: both flowrate stds below ``converged_std_fraction`` of nominal, both estimates changed by
  less than ``converged_drift_fraction`` of nominal over the last ``converged_window_s``, and some channel
  updated the filter within that window.
"""

from __future__ import annotations

import math

import numpy as np

from oilwatch.models.validation import InputError

from . import channels
from .alarm import StarvationAlarm
from .baseline_change import new_change_array, reference_applies, reset_change
from .ekf_batch import BatchRuns
from .ekf_config import EKFConfig
from .ekf_prediction import ModelPrediction
from .ekf_reporting import FilterReporting
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
from .reports import StepReport
from .runout import RunoutCompensation
from .state import FilterStateIO
from .step_kernel import (
    COUNT_SINCE_UPDATE,
    COUNT_STEP,
    REPORT_SIZE,
    REPORT_STD,
    SUMMARY_STD_FLOOR,
    ekf_step,
)


class OilFlowEKF(FilterReporting, BatchRuns, ModelPrediction, FilterStateIO):
    """Augmented-state EKF estimating (q1, q2) from the four measured bearing displacements.

    Parameters
    ----------
    model : any :class:`oilwatch.estimator.model.AugmentedModel`.
    config : :class:`oilwatch.estimator.ekf_config.EKFConfig` (paper defaults; what it leaves open, e.g. the
    nominal
        flowrate, comes from the model: :meth:`EKFConfig.for_model`).

    ``state_layout`` (:class:`oilwatch.estimator.ekf_setup.StateLayout`) tells where each part sits in the
    state vector ``x`` of :meth:`get_state` (the flowrates in fractions of ``config.q_nominal_m3_s``).

    The set-up is :mod:`oilwatch.estimator.ekf_setup`, the reported estimates
    :mod:`oilwatch.estimator.ekf_reporting`, the record entries (:meth:`run`, :meth:`run_batch`)
    :mod:`oilwatch.estimator.ekf_batch`, the model's transition with the nuisance columns and the operating
    point :mod:`oilwatch.estimator.ekf_prediction`, the state's export and import
    :mod:`oilwatch.estimator.state`.
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
        self._q_nominal = cfg.q_nominal_m3_s
        low, high = model.flowrate_bounds_m3_s
        self._bounds = (float(low), float(high))
        bounds_scaled = (low / self._q_nominal, high / self._q_nominal)
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
        self._consistency_steps = max(1, round(cfg.consistency_window_s / self._dt))
        unbalance_walk = cfg.unbalance_random_walk_sqrt_s**2 * self._dt
        self._summary_settings = summary_settings(cfg, self._q_nominal, self._bounds, unbalance_walk)
        self._report = np.zeros(REPORT_SIZE)
        self._batch_table = np.empty((0, REPORT_SIZE))
        self._one_row = np.empty((1, REPORT_SIZE))
        # a grid model at one speed with no nuisance in its transition: whole batches in one compiled call
        batch = getattr(model, "batch_transition", None)
        plain = not (
            self._follows or self._n_unbalance or self._n_viscosity or self._runout.vectors is not None
        )
        self._grid_batch = batch() if callable(batch) and plain else None
        self._batch_next, self._batch_exogenous = np.zeros(n), np.zeros(3)
        self._batch_transition, self._batch_flow_jacobian = np.zeros((n, n)), np.zeros((n, 2))
        self._counters = layout.counters()
        self._process_noise = process_noise(model, cfg, layout, self._dt, self._q_var, unbalance_walk)

        self._jacobian = np.zeros((self._size, self._size))
        self._work = np.zeros((self._size, self._size))
        self._z8 = np.zeros(8)
        self._accepted = np.zeros(4, dtype=bool)
        self._window = max(1, round(cfg.converged_window_s / self._dt))
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
        self._shadow = ShadowJacobian(n, self._n_trailing) if free and cfg.nuisance_shadow else None
        floor = self._shadow is not None and cfg.nuisance_information_floor and hasattr(model, "maps")
        self._floor = InformationFloor(model, cfg, n, self._n_offsets, self._n_unbalance) if floor else None
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
            self.model, n, cfg.initial_displacement_std_m, cfg.initial_velocity_std_m_s
        )
        self._P[n : n + 2, n : n + 2] = (cfg.initial_flowrate_std_m3_s / self._q_nominal) ** 2 * np.eye(2)
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
        self._process_noise[n : n + 2, n : n + 2] = self._q_var * np.eye(2)
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
            next_state, state_jac, flow_jac = self._x[:n], self._work[:n, :n], self._work[:n, :2]
        ekf_step(predict, next_state, state_jac, flow_jac, displacement, self._packed)
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
            reported = self._report[REPORT_STD : REPORT_STD + 2]
            np.maximum(reported, self._floor.std, out=reported)
        if self._floor is not None and step >= self._settling:  # the alarm's floor from the next step
            self._summary_settings[SUMMARY_STD_FLOOR : SUMMARY_STD_FLOOR + 2] = self._floor.std

    def get_state(self) -> dict[str, np.ndarray]:
        """The complete filter state as copies of numpy arrays (restoring it continues bit-identically)."""
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
            self._summary_settings[SUMMARY_STD_FLOOR : SUMMARY_STD_FLOOR + 2] = (
                self._floor.std if applied else 0.0
            )
