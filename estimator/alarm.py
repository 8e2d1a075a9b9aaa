"""Per-bearing oil-starvation alarm on the EKF's flowrate estimates, with hold times and hysteresis.

Rule (one per bearing i, evaluated every step from the estimate q_i and its std sigma_i from P):

* SET when the upper confidence bound ``q_i + z sigma_i`` has stayed below ``on_fraction * q_nominal`` for
  ``hold_on_s`` without interruption: the estimate is confidently low, not merely noisy or still uncertain
  (at start-up sigma_i is large, so an unconverged filter cannot raise the alarm).
* CLEAR when the lower bound ``q_i - z sigma_i`` has stayed above ``off_fraction * q_nominal`` for
  ``hold_off_s``: a clearly recovered flow, with a gap between the two levels so that an estimate hovering
  near one threshold cannot make the alarm chatter.

Each alarm also records whether the estimator's model was consistent with the data (``model_consistent`` of
:mod:`estimator.ekf`) when it was raised: ``starved_consistent``. An alarm raised while the model was not
consistent may be the machine's departure from the model rather than starvation.

Defaults (:class:`estimator.config.AlarmConfig`): z = 2, 90 % to set, 95 % to clear, holds 0.25 s and 1 s.
Designed for: firing within 2 s of the centre of a sudden 25 % drop and never in a 20 s nominal run at sigma
1 um (both checked in ``tests/test_estimator_alarm.py``).
"""

from __future__ import annotations

import numpy as np

from models.validation import InputError

from .config import AlarmConfig

_STATE_KEYS = ("alarm_starved", "alarm_on_count", "alarm_off_count", "alarm_raised_consistent")


class StarvationAlarm:
    """The alarm of the module docstring for ``n_bearings`` bearings.

    Parameters
    ----------
    config : thresholds. dt_s : step [s]. q_nominal_m3_s : reference flowrate [m^3/s].
    """

    def __init__(self, config: AlarmConfig, dt_s: float, q_nominal_m3_s: float, n_bearings: int = 2) -> None:
        self.config = config
        self._on_level = config.on_fraction * q_nominal_m3_s
        self._off_level = config.off_fraction * q_nominal_m3_s
        self._hold_on_steps = max(1, round(config.hold_on_s / dt_s))
        self._hold_off_steps = max(1, round(config.hold_off_s / dt_s))
        self._starved = np.zeros(n_bearings, dtype=bool)
        self._on_count = np.zeros(n_bearings, dtype=np.int64)
        self._off_count = np.zeros(n_bearings, dtype=np.int64)
        self._raised_consistent = np.zeros(n_bearings, dtype=bool)

    @property
    def starved(self) -> np.ndarray:
        """(n_bearings,) bool copy of the current alarm flags."""
        return self._starved.copy()

    @property
    def starved_consistent(self) -> np.ndarray:
        """(n_bearings,) bool: the alarm is set and was raised while the model was consistent."""
        return self._starved & self._raised_consistent

    def update(
        self, flowrate_m3_s: np.ndarray, std_m3_s: np.ndarray, model_consistent: bool = True
    ) -> np.ndarray:
        """Advance one step with the estimates and stds [m^3/s], (n_bearings,) each, and the model
        consistency flag of this step; return the alarm flags."""
        z = self.config.confidence_z
        for i in range(self._starved.size):
            if self._starved[i]:
                recovered = flowrate_m3_s[i] - z * std_m3_s[i] > self._off_level
                self._off_count[i] = self._off_count[i] + 1 if recovered else 0
                if self._off_count[i] >= self._hold_off_steps:
                    self._starved[i] = False
                    self._off_count[i] = 0
            else:
                low = flowrate_m3_s[i] + z * std_m3_s[i] < self._on_level
                self._on_count[i] = self._on_count[i] + 1 if low else 0
                if self._on_count[i] >= self._hold_on_steps:
                    self._starved[i] = True
                    self._raised_consistent[i] = model_consistent
                    self._on_count[i] = 0
        return self._starved.copy()

    def get_state(self) -> dict[str, np.ndarray]:
        """Copies of the complete alarm state (flags and hold counters)."""
        return {
            "alarm_starved": self._starved.copy(),
            "alarm_on_count": self._on_count.copy(),
            "alarm_off_count": self._off_count.copy(),
            "alarm_raised_consistent": self._raised_consistent.copy(),
        }

    def set_state(self, state: dict[str, np.ndarray]) -> None:
        """Restore a state from :meth:`get_state` exactly."""
        for key in _STATE_KEYS:
            if key not in state:
                raise InputError(f"alarm state lacks {key!r}")
            if np.shape(state[key]) != self._starved.shape:
                raise InputError(
                    f"alarm state {key!r} must have shape {self._starved.shape}, got {np.shape(state[key])}"
                )
        self._starved[:] = np.asarray(state["alarm_starved"], dtype=bool)
        self._on_count[:] = np.asarray(state["alarm_on_count"], dtype=np.int64)
        self._off_count[:] = np.asarray(state["alarm_off_count"], dtype=np.int64)
        self._raised_consistent[:] = np.asarray(state["alarm_raised_consistent"], dtype=bool)
