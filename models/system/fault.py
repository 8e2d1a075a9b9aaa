"""Supply-flowrate fault injection: a logistic (sigmoid) transition between two flowrates.

``q(t) = q_initial + (q_final - q_initial) / (1 + exp(-(t - t_c) / tau))``

``t_c`` is the centre (half the change done). The transition duration ``D`` is the 10 %-90 % rise time: the
time the flowrate takes to cover the middle 80 % of the change, so ``tau = D / (2 ln 9)``. It is the usual
definition of a rise time and it does not depend on the size of the change.

The paper shows slow, intermediate and sudden drops (Fig. 10) without numbers; oilwatch uses
``SCENARIO_DURATIONS_S``: 4 s (slow), 1 s (intermediate) and 0.1 s (sudden), centred at 10 s in a 20 s record,
which reproduces the look of the paper's figures (a sudden drop within one or two hundred samples, a slow one
spanning a good part of the record).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..validation import require_finite, require_non_negative, require_positive

RISE_TIME_FACTOR = 2.0 * np.log(9.0)
SCENARIO_DURATIONS_S = {"slow": 4.0, "intermediate": 1.0, "sudden": 0.1}


@dataclass(frozen=True)
class SigmoidFlowrate:
    """A logistic transition of one bearing's supply flowrate (SI units, m^3/s and s)."""

    initial_m3_s: float
    final_m3_s: float
    centre_s: float
    duration_s: float

    def __post_init__(self) -> None:
        require_non_negative("initial flowrate", self.initial_m3_s, "m^3/s")
        require_non_negative("final flowrate", self.final_m3_s, "m^3/s")
        require_finite("fault_time_s", self.centre_s)
        require_positive("fault_duration_s", self.duration_s, "s")

    @property
    def time_constant_s(self) -> float:
        """Logistic time constant ``tau = D / (2 ln 9)`` [s]."""
        return self.duration_s / RISE_TIME_FACTOR

    def __call__(self, time_s: float | np.ndarray) -> float | np.ndarray:
        """The flowrate [m^3/s] at time(s) ``time_s`` [s]."""
        x = (np.asarray(time_s, dtype=float) - self.centre_s) / self.time_constant_s
        # 1 / (1 + exp(-x)) = (1 + tanh(x / 2)) / 2, which never overflows.
        fraction = 0.5 + 0.5 * np.tanh(0.5 * x)
        value = self.initial_m3_s + (self.final_m3_s - self.initial_m3_s) * fraction
        return float(value) if np.ndim(value) == 0 else value
