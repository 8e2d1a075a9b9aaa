"""Speed-dependent stability of the rotor on its fluid-film bearings: first critical speed and threshold.

At each speed of a sweep the bearings' stiffness and damping are those the film has at that speed
(``speed_sweep``). Definitions used (and printed with the results):

* first critical speed: the lowest speed at which a forward-whirl damped natural frequency equals the spin
  frequency (the 1x line of the Campbell diagram crosses it);
* instability threshold: the lowest speed at which the least-stable mode's logarithmic decrement crosses
  zero (oil whirl/whip onset), linearly interpolated between sweep speeds.

Reference: Friswell et al., Dynamics of Rotating Machines (2010), sections 3.6 and 5.9.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..rotor.assembly import Rotor
from ..rotor.modal import CampbellDiagram, campbell_diagram
from .speed_sweep import SpeedSweep
from .supports import swept_bearings


@dataclass(frozen=True)
class StabilityMap:
    """Campbell diagram with speed-dependent bearings and the two speeds derived from it.

    ``first_critical_hz`` / ``instability_threshold_hz`` are None when the sweep does not reach them.
    """

    campbell: CampbellDiagram
    least_log_decrement: np.ndarray
    first_critical_hz: float | None
    instability_threshold_hz: float | None


def stability_map(
    rotor: Rotor, sweeps: Sequence[SpeedSweep], speeds_hz: np.ndarray, n_modes: int = 8
) -> StabilityMap:
    """Damped modes over ``speeds_hz`` [Hz] with the swept bearing coefficients, and the derived speeds."""
    campbell = campbell_diagram(rotor, speeds_hz, swept_bearings(rotor, sweeps), n_modes)
    least = np.nanmin(campbell.log_decrements, axis=1)
    criticals = campbell.critical_speeds_hz()
    return StabilityMap(
        campbell=campbell,
        least_log_decrement=least,
        first_critical_hz=criticals[0] if criticals else None,
        instability_threshold_hz=_first_zero_crossing(campbell.speeds_hz, least),
    )


def _first_zero_crossing(speeds: np.ndarray, values: np.ndarray) -> float | None:
    """Lowest speed where ``values`` goes from positive to non-positive (linear interpolation)."""
    for i in range(len(speeds) - 1):
        if values[i] > 0.0 >= values[i + 1]:
            return float(speeds[i] + (speeds[i + 1] - speeds[i]) * values[i] / (values[i] - values[i + 1]))
    return None
