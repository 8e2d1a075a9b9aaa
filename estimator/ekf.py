"""The augmented-state Extended Kalman Filter that estimates the two oil supply flowrates (paper Eqs. 17-24).

Augmented state ``x = [s; q / q_nominal]``: the model's dynamic states ``s`` (SI) and the two flowrates as
fractions of the nominal flowrate. The model works in m^3/s, where a flowrate of 1e-5 and a process-noise std
of 1.7e-9 sit beside displacements of 1e-5 m; in fractions of nominal the flowrate entries of P are
O(1e-4..1e-1), which keeps the flowrate block of P and its Jacobian columns well scaled. Everything at the
interface is SI.

Per step (:meth:`OilFlowEKF.step`): predict with the model (Eqs. 19-21, skipped on the very first sample),
then update with the measured displacements (Eqs. 22-24, Joseph form, Cholesky solve; see
:mod:`estimator.kernels`).

* Bad input: a NaN or infinite sample skips the update (prediction only) and reports ``measurement_ok`` false.
* Innovation gate: a sample whose NIS exceeds the chi-square quantile ``1 - gate_tail_probability`` for its
  number of channels is rejected like a bad sample; after ``gate_max_consecutive_rejections`` rejections in a
  row the next sample is used regardless, so that a genuine abrupt change cannot lock the filter out.
* Differentiated velocities use only two consecutive accepted samples; after a skipped or rejected sample the
  next update uses the four displacements alone.
* Flowrate bounds: after each update, a flowrate outside the coefficient table's range is projected onto it in
  the metric of P^-1 (Simon & Chia, IEEE Trans. AES 38, 2002: the minimum-variance estimate given that the
  active bound holds exactly), which also moves the correlated dynamic states; P is left unchanged, a
  conservative choice that keeps the flowrate free to leave the bound (the projected covariance would have
  zero variance there). The model is therefore never evaluated outside its table.
* ``converged``: both flowrate stds below ``converged_std_fraction`` of nominal and both estimates changed by
  less than ``converged_drift_fraction`` of nominal over the last ``converged_window_s``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.special import chdtri

from models.validation import InputError

from .alarm import StarvationAlarm
from .config import EKFConfig
from .kernels import UPDATE_ACCEPTED, filter_step
from .measurement import displacement_channels, velocity_channels
from .model import AugmentedModel, has_static_state
from .state import export_state, import_state


@dataclass(slots=True)
class StepReport:
    """What the filter reports after one sample.

    step : index k of the sample just processed. q_m3_s, q_std_m3_s : (2,) estimates and their stds from P
    [m^3/s]. nis : normalized innovation squared of this sample (0 when no update was attempted).
    n_measurements : channels used by the update (8, 4, or 0 when skipped or rejected). converged : see module
    docstring. measurement_ok : the sample was finite and passed the gate. starved : (2,) bool alarm flags.
    """

    step: int
    q_m3_s: np.ndarray
    q_std_m3_s: np.ndarray
    nis: float
    n_measurements: int
    converged: bool
    measurement_ok: bool
    starved: np.ndarray


@dataclass
class EstimateTrace:
    """Per-step outputs of :meth:`OilFlowEKF.run` for K samples: arrays (K, 2) or (K,), fields as
    StepReport."""

    q_m3_s: np.ndarray
    q_std_m3_s: np.ndarray
    nis: np.ndarray
    n_measurements: np.ndarray
    converged: np.ndarray
    measurement_ok: np.ndarray
    starved: np.ndarray


class OilFlowEKF:
    """Augmented-state EKF estimating (q1, q2) from the four measured bearing displacements.

    Parameters
    ----------
    model : any :class:`estimator.model.AugmentedModel`.
    config : :class:`estimator.config.EKFConfig` (paper defaults; what it leaves open, e.g. the nominal
        flowrate, comes from the model: :meth:`EKFConfig.for_model`).
    """

    def __init__(self, model: AugmentedModel, config: EKFConfig | None = None) -> None:
        self.model = model
        self.config = (config if config is not None else EKFConfig()).for_model(model)
        self._check_model()
        cfg = self.config
        n = int(model.n_states)
        self._n = n
        self._size = n + 2
        self._q_nominal = cfg.q_nominal_m3_s
        low, high = model.flowrate_bounds_m3_s
        self._bounds = (float(low), float(high))
        self._bounds_scaled = (low / self._q_nominal, high / self._q_nominal)
        self._dt = float(model.dt_s)
        self._first_step = round(cfg.first_sample_time_s / self._dt)
        if abs(self._first_step * self._dt - cfg.first_sample_time_s) > 1e-6 * self._dt:
            raise InputError(
                f"EKFConfig.first_sample_time_s must be a multiple of the model's dt = {self._dt:g} s, "
                f"got {cfg.first_sample_time_s:g} s"
            )

        self._obs4, self._noise4 = displacement_channels(model, cfg.noise_std_m)
        channels8 = velocity_channels(model, cfg.noise_std_m, cfg.velocity_noise)
        # displacement-only: empty eight-channel arrays tell the compiled step to use four channels
        self._obs8, self._noise8 = (
            channels8 if channels8 is not None else (np.zeros((0, self._size)), np.zeros((0, 0)))
        )
        p = cfg.gate_tail_probability
        # chdtri(m, p) is the chi-square quantile with upper tail p (m degrees of freedom)
        gate4 = float(chdtri(4, p)) if p > 0.0 else np.inf
        gate8 = float(chdtri(8, p)) if p > 0.0 else np.inf
        self._settings = np.array(
            [
                gate4,
                gate8,
                float(cfg.gate_max_consecutive_rejections),
                1.0 / self._dt,
                *self._bounds_scaled,
            ]
        )

        self._process_noise = np.zeros((self._size, self._size))
        self._process_noise[:n, :n] = self._physical(
            cfg.displacement_process_std_m, cfg.velocity_process_std_m_s
        )
        q_var = (cfg.flowrate_process_std_m3_s / self._q_nominal) ** 2
        self._process_noise[n:, n:] = q_var * np.eye(2)

        self._jacobian = np.zeros((self._size, self._size))
        self._work = np.zeros((self._size, self._size))
        self._z8 = np.zeros(8)
        self._window = max(1, round(cfg.converged_window_s / self._dt))
        self.alarm = StarvationAlarm(cfg.alarm, self._dt, self._q_nominal)
        self.reset()

    def _check_model(self) -> None:
        model = self.model
        n = model.n_states
        if not isinstance(n, int | np.integer) or n < 1:
            raise InputError(f"model.n_states must be a positive integer, got {n!r}")
        for name in ("output_matrix", "velocity_output_matrix"):
            shape = np.shape(getattr(model, name))
            if shape != (4, n):
                raise InputError(f"model.{name} must have shape (4, {n}), got {shape}")
        if not float(model.dt_s) > 0.0:
            raise InputError(f"model.dt_s must be > 0 s, got {model.dt_s!r}")
        low, high = model.flowrate_bounds_m3_s
        if not 0.0 < low < high:
            raise InputError(f"model.flowrate_bounds_m3_s must satisfy 0 < low < high, got {low}, {high}")
        for value in self.config.q_initial_pair():
            if not low <= value <= high:
                raise InputError(
                    f"EKFConfig.q_initial_m3_s must lie in the model's table range "
                    f"[{low:g}, {high:g}] m^3/s, got {value:g}"
                )
        if self.config.initial_state == "static" and not has_static_state(model):
            raise InputError("EKFConfig.initial_state='static' needs a model with static_state()")

    def _physical(self, displacement_std: float, velocity_std: float) -> np.ndarray:
        n = self._n
        if displacement_std == 0.0 and velocity_std == 0.0:
            return np.zeros((n, n))
        covariance = np.asarray(self.model.physical_covariance(displacement_std, velocity_std))
        if covariance.shape != (n, n):
            raise InputError(
                f"model.physical_covariance must return shape ({n}, {n}), got {covariance.shape}"
            )
        return 0.5 * (covariance + covariance.T)

    def reset(self) -> None:
        """Return to the initial estimate and covariance of the configuration (step 0)."""
        cfg = self.config
        n = self._n
        q0 = np.array(cfg.q_initial_pair())
        self._x = np.zeros(self._size)
        if cfg.initial_state == "static":
            self._x[:n] = self.model.static_state(q0)
        self._x[n:] = q0 / self._q_nominal
        self._P = np.zeros((self._size, self._size))
        self._P[:n, :n] = self._physical(cfg.initial_displacement_std_m, cfg.initial_velocity_std_m_s)
        self._P[n:, n:] = (cfg.initial_flowrate_std_m3_s / self._q_nominal) ** 2 * np.eye(2)
        self._previous = np.zeros(4)
        self._counters = np.zeros(2, dtype=np.int64)  # previous sample valid, consecutive rejections
        self._step = 0
        self._history = np.zeros((self._window, 2))
        self._last = (0.0, 0, False, False)
        self.alarm = StarvationAlarm(cfg.alarm, self._dt, self._q_nominal)

    @property
    def flowrate_m3_s(self) -> np.ndarray:
        """(2,) current flowrate estimates [m^3/s], inside the model's table range."""
        return np.array(self._flowrate_si())

    def _flowrate_si(self) -> tuple[float, float]:
        # clipped in SI as well: the round trip through the scaled unit may leave a bound by one ulp
        n, scale = self._n, self._q_nominal
        low, high = self._bounds
        return (
            min(max(float(self._x[n]) * scale, low), high),
            min(max(float(self._x[n + 1]) * scale, low), high),
        )

    @property
    def flowrate_std_m3_s(self) -> np.ndarray:
        """(2,) standard deviations of the flowrate estimates from P [m^3/s]."""
        n = self._n
        return np.sqrt(np.diag(self._P)[n:]) * self._q_nominal

    @property
    def dynamic_state(self) -> np.ndarray:
        """(n,) copy of the dynamic-state estimate s [SI]."""
        return self._x[: self._n].copy()

    @property
    def covariance(self) -> np.ndarray:
        """(n + 2, n + 2) copy of P; the flowrate block is in the internal unit (fractions of nominal)^2."""
        return self._P.copy()

    def current_report(self) -> StepReport:
        """The report of the last processed sample, rebuilt from the state (e.g. after :meth:`set_state`)."""
        nis, channels, ok, converged = self._last
        return StepReport(
            self._step - 1,
            self.flowrate_m3_s,
            self.flowrate_std_m3_s,
            nis,
            channels,
            converged,
            ok,
            self.alarm.starved,
        )

    @property
    def step_count(self) -> int:
        """Number of samples processed."""
        return self._step

    def step(self, displacement_m: np.ndarray) -> StepReport:
        """Process one sample of the measured displacements (x1, y1, x2, y2) [m], shape (4,).

        The sample belongs to time ``first_sample_time_s + k dt`` with k = :attr:`step_count`; the prediction
        from the previous sample runs first. Non-finite entries mean a bad sample.
        """
        displacement = np.ascontiguousarray(displacement_m, dtype=np.float64)
        if displacement.shape != (4,):
            raise InputError(f"displacement_m must have shape (4,), got {displacement.shape}")
        n = self._n
        predict = self._step > 0
        if predict:
            next_state, state_jac, flow_jac = self.model.transition(
                self._x[:n], np.array(self._flowrate_si()), self._first_step + self._step - 1
            )
        else:
            next_state, state_jac, flow_jac = self._x[:n], self._work[:n, :n], self._work[:n, :2]
        status, nis, channels = filter_step(
            self._x,
            self._P,
            predict,
            np.ascontiguousarray(next_state, dtype=np.float64),
            np.ascontiguousarray(state_jac, dtype=np.float64),
            np.ascontiguousarray(flow_jac, dtype=np.float64),
            self._q_nominal,
            self._process_noise,
            self._jacobian,
            self._work,
            displacement,
            self._previous,
            self._counters,
            self._z8,
            self._obs4,
            self._noise4,
            self._obs8,
            self._noise8,
            self._settings,
        )
        ok = status == UPDATE_ACCEPTED
        if not math.isfinite(nis):
            nis = 0.0
        deviation = (math.sqrt(self._P[n, n]), math.sqrt(self._P[n + 1, n + 1]))
        converged = self._converged((float(self._x[n]), float(self._x[n + 1])), deviation)
        q = np.array(self._flowrate_si())
        std = np.array(deviation) * self._q_nominal
        starved = self.alarm.update(q, std)
        self._last = (nis, channels, ok, converged)
        report = StepReport(self._step, q, std, nis, channels, converged, ok, starved)
        self._step += 1
        return report

    def _converged(self, scaled: tuple[float, float], deviation: tuple[float, float]) -> bool:
        """Apply the convergence rule to q / q_nominal and its std; record q for the drift test."""
        cfg = self.config
        history = self._history
        slot = self._step % self._window
        drift = max(abs(scaled[0] - history[slot, 0]), abs(scaled[1] - history[slot, 1]))
        history[slot, 0] = scaled[0]
        history[slot, 1] = scaled[1]
        return (
            self._step >= self._window
            and max(deviation) < cfg.converged_std_fraction
            and drift < cfg.converged_drift_fraction
        )

    def run(
        self, displacements_m: np.ndarray, progress: Callable[[int, int], None] | None = None
    ) -> EstimateTrace:
        """Process a record of K samples (K, 4) [m] with :meth:`step`; return the per-step outputs.

        ``progress(done, total)`` is called every 100 samples and at the end (for a progress bar)."""
        record = np.asarray(displacements_m, dtype=np.float64)
        if record.ndim != 2 or record.shape[1] != 4:
            raise InputError(f"displacements_m must have shape (K, 4), got {record.shape}")
        count = record.shape[0]
        trace = EstimateTrace(
            q_m3_s=np.zeros((count, 2)),
            q_std_m3_s=np.zeros((count, 2)),
            nis=np.zeros(count),
            n_measurements=np.zeros(count, dtype=np.int64),
            converged=np.zeros(count, dtype=bool),
            measurement_ok=np.zeros(count, dtype=bool),
            starved=np.zeros((count, 2), dtype=bool),
        )
        for k in range(count):
            if progress is not None and k % 100 == 0:
                progress(k, count)
            report = self.step(record[k])
            trace.q_m3_s[k] = report.q_m3_s
            trace.q_std_m3_s[k] = report.q_std_m3_s
            trace.nis[k] = report.nis
            trace.n_measurements[k] = report.n_measurements
            trace.converged[k] = report.converged
            trace.measurement_ok[k] = report.measurement_ok
            trace.starved[k] = report.starved
        if progress is not None:
            progress(count, count)
        return trace

    def get_state(self) -> dict[str, np.ndarray]:
        """The complete filter state as copies of numpy arrays (restoring it continues bit-identically)."""
        return export_state(self)

    def set_state(self, state: dict[str, np.ndarray]) -> None:
        """Restore a state from :meth:`get_state` exactly (same model and configuration)."""
        import_state(self, state)
