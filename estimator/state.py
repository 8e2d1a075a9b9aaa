"""Export and import of the complete EKF state, so that an FMU can save and restore it bit-identically:
the :class:`FilterStateIO` half of :class:`oilwatch.estimator.ekf.OilFlowEKF`.

The state is a flat ``dict[str, numpy.ndarray]`` (scalars as 0-d arrays), every array a copy:

====================  ==========  =====================================================================
key                   shape       meaning
====================  ==========  =====================================================================
x                     (N,)        [s; q / q_nominal; offsets, viscosity factors, unbalance if estimated]
P                     (N, N)      its covariance
health                (4, 6)      int: probe records (:mod:`oilwatch.estimator.channels`)
health_values         (4, 4)      float: last reading, innovation power and mean, last accepted reading
step                  ()          int: samples processed
since_update          ()          int: samples since the last update that used a channel
q_history             (W, 2)      ring buffer of q / q_nominal for the convergence drift test
nis_window            (C, 2)      ring buffer of NIS and rows for the consistency test
nis_sums              (2,)        their running sums
process_noise_q       (2,)        the flowrate process variances of the next prediction (change test)
changing              (2,)        bool: change test firing per bearing
last                  (5,)        float: nis, n_measurements, measurement_ok, converged, model_consistent
alarm_*               (2,)        the alarm flags and hold counters (see :mod:`oilwatch.estimator.alarm`)
operating             (4,)        (given?, speed [Hz], given?, oil temperature [degC]) last measured
model_mismatch        (M,)        the mismatch status and static means (estimator.baseline_change)
published             (5,)        the published flowrates and stds and the mismatch status
model_*               ...         a model's operating state, when it follows the operating point
====================  ==========  =====================================================================
"""

from __future__ import annotations

import numpy as np

from oilwatch.models.validation import InputError

from .step_kernel import COUNT_SINCE_UPDATE, COUNT_STEP, REPORT_FLOWRATE, REPORT_MISMATCH, REPORT_STD

_PUBLISHED = (REPORT_FLOWRATE, REPORT_FLOWRATE + 1, REPORT_STD, REPORT_STD + 1, REPORT_MISMATCH)


def _checked(state: dict[str, np.ndarray], key: str, shape: tuple[int, ...]) -> np.ndarray:
    if key not in state:
        raise InputError(f"EKF state lacks {key!r}")
    value = np.asarray(state[key])
    if value.shape != shape:
        raise InputError(f"EKF state {key!r} must have shape {shape}, got {value.shape}")
    return value


class FilterStateIO:
    """The state half of :class:`oilwatch.estimator.ekf.OilFlowEKF` (which sets up the attributes used
    here)."""

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
            model_state = {k.removeprefix("model_"): v for k, v in state.items() if k.startswith("model_")}
            if model_state:
                setter(model_state)
