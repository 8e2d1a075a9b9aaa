"""Export and import of the complete EKF state, so that an FMU can save and restore it bit-identically.

The state is a flat ``dict[str, numpy.ndarray]`` (scalars as 0-d arrays), every array a copy:

====================  ==========  =====================================================================
key                   shape       meaning
====================  ==========  =====================================================================
x                     (n+2,)      augmented estimate [s; q / q_nominal]
P                     (n+2, n+2)  its covariance
previous              (4,)        last accepted displacement sample [m] (for the differentiated velocity)
previous_valid        ()          bool: ``previous`` may be differentiated against
step                  ()          int: samples processed
rejections            ()          int: consecutive gate rejections
q_history             (W, 2)      ring buffer of q / q_nominal for the convergence drift test
last                  (4,)        float: nis, n_measurements, measurement_ok, converged of the last step
alarm_*               (2,)        the alarm flags and hold counters (see :mod:`estimator.alarm`)
====================  ==========  =====================================================================
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from models.validation import InputError

from .kernels import PREVIOUS_VALID, REJECTIONS

if TYPE_CHECKING:
    from .ekf import OilFlowEKF


def export_state(ekf: OilFlowEKF) -> dict[str, np.ndarray]:
    """Return the state of ``ekf`` as a dict of array copies."""
    nis, channels, ok, converged = ekf._last
    state = {
        "x": ekf._x.copy(),
        "P": ekf._P.copy(),
        "previous": ekf._previous.copy(),
        "previous_valid": np.array(bool(ekf._counters[PREVIOUS_VALID])),
        "step": np.array(ekf._step, dtype=np.int64),
        "rejections": np.array(ekf._counters[REJECTIONS], dtype=np.int64),
        "q_history": ekf._history.copy(),
        "last": np.array([nis, channels, float(ok), float(converged)]),
    }
    state.update(ekf.alarm.get_state())
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
    ekf._previous[:] = _checked(state, "previous", (4,))
    ekf._counters[PREVIOUS_VALID] = int(bool(_checked(state, "previous_valid", ())))
    ekf._step = int(_checked(state, "step", ()))
    ekf._counters[REJECTIONS] = int(_checked(state, "rejections", ()))
    ekf._history[:, :] = _checked(state, "q_history", ekf._history.shape)
    nis, channels, ok, converged = _checked(state, "last", (4,))
    ekf._last = (float(nis), int(channels), bool(ok), bool(converged))
    ekf.alarm.set_state(state)
