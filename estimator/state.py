"""Export and import of the complete EKF state, so that an FMU can save and restore it bit-identically.

The state is a flat ``dict[str, numpy.ndarray]`` (scalars as 0-d arrays), every array a copy:

====================  ==========  =====================================================================
key                   shape       meaning
====================  ==========  =====================================================================
x                     (N,)        [s; q / q_nominal; offsets, viscosity factors, unbalance if estimated]
P                     (N, N)      its covariance
health                (4, 6)      int: probe records (:mod:`estimator.channels`)
health_values         (4, 4)      float: last reading, innovation power and mean, last accepted reading
step                  ()          int: samples processed
since_update          ()          int: samples since the last update that used a channel
q_history             (W, 2)      ring buffer of q / q_nominal for the convergence drift test
nis_window            (C, 2)      ring buffer of NIS and rows for the consistency test
nis_sums              (2,)        their running sums
process_noise_q       (2,)        the flowrate process variances of the next prediction (change test)
changing              (2,)        bool: change test firing per bearing
last                  (5,)        float: nis, n_measurements, measurement_ok, converged, model_consistent
alarm_*               (2,)        the alarm flags and hold counters (see :mod:`estimator.alarm`)
operating             (4,)        (given?, speed [Hz], given?, oil temperature [degC]) last measured
model_*               ...         a model's operating state, when it follows the operating point
====================  ==========  =====================================================================
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from models.validation import InputError

from .step_kernel import COUNT_SINCE_UPDATE, COUNT_STEP

if TYPE_CHECKING:
    from .ekf import OilFlowEKF


def export_state(ekf: OilFlowEKF) -> dict[str, np.ndarray]:
    """Return the state of ``ekf`` as a dict of array copies."""
    n = ekf._n
    state = {
        "x": ekf._x.copy(),
        "P": ekf._P.copy(),
        "health": ekf._health.copy(),
        "health_values": ekf._health_values.copy(),
        "step": np.array(ekf.step_count, dtype=np.int64),
        "since_update": np.array(ekf._counters[COUNT_SINCE_UPDATE], dtype=np.int64),
        "q_history": ekf._history.copy(),
        "nis_window": ekf._nis_window.copy(),
        "nis_sums": ekf._nis_sums.copy(),
        "process_noise_q": np.diag(ekf._process_noise)[n : n + 2].copy(),
        "changing": ekf._changing.copy(),
        "last": np.array([float(v) for v in ekf._last]),
    }
    state.update(ekf.alarm.get_state())
    speed, temperature = ekf._operating
    state["operating"] = np.array(
        [float(speed is not None), speed or 0.0, float(temperature is not None), temperature or 0.0]
    )
    getter = getattr(ekf.model, "get_operating_state", None)
    if callable(getter):
        state.update({f"model_{key}": value for key, value in getter().items()})
    return state


def _checked(state: dict[str, np.ndarray], key: str, shape: tuple[int, ...]) -> np.ndarray:
    if key not in state:
        raise InputError(f"EKF state lacks {key!r}")
    value = np.asarray(state[key])
    if value.shape != shape:
        raise InputError(f"EKF state {key!r} must have shape {shape}, got {value.shape}")
    return value


def import_state(ekf: OilFlowEKF, state: dict[str, np.ndarray]) -> None:
    """Restore ``state`` (from :func:`export_state` of a filter with the same model and config) into
    ``ekf``."""
    size = ekf._size
    x = _checked(state, "x", (size,))
    covariance = _checked(state, "P", (size, size))
    if not (np.isfinite(x).all() and np.isfinite(covariance).all()):
        raise InputError("EKF state 'x' and 'P' must be finite")
    ekf._x[:] = x
    ekf._P[:, :] = covariance
    ekf._health[:, :] = _checked(state, "health", ekf._health.shape)
    ekf._health_values[:, :] = _checked(state, "health_values", ekf._health_values.shape)
    ekf._counters[COUNT_STEP] = int(_checked(state, "step", ()))
    ekf._counters[COUNT_SINCE_UPDATE] = int(_checked(state, "since_update", ()))
    ekf._history[:, :] = _checked(state, "q_history", ekf._history.shape)
    ekf._nis_window[:, :] = _checked(state, "nis_window", ekf._nis_window.shape)
    ekf._nis_sums[:] = _checked(state, "nis_sums", (2,))
    n = ekf._n
    noise = _checked(state, "process_noise_q", (2,))
    ekf._process_noise[n, n], ekf._process_noise[n + 1, n + 1] = float(noise[0]), float(noise[1])
    ekf._changing[:] = _checked(state, "changing", (2,))
    nis, rows, ok, converged, consistent = _checked(state, "last", (5,))
    ekf.alarm.set_state(state)
    ekf._set_last(float(nis), int(rows), bool(ok), bool(converged), bool(consistent))
    if "operating" in state:
        has_speed, speed, has_temperature, temperature = (
            float(v) for v in _checked(state, "operating", (4,))
        )
        ekf._operating = (speed if has_speed else None, temperature if has_temperature else None)
    setter = getattr(ekf.model, "set_operating_state", None)
    if callable(setter):
        model_state = {k.removeprefix("model_"): v for k, v in state.items() if k.startswith("model_")}
        if model_state:
            setter(model_state)
