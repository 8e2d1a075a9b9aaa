"""Probe health and the per-channel innovation gate: a faulty probe is the probe's fault, not the oil's.

Every sample, each of the four displacement channels is screened (compiled, :func:`screen_channels`) before
the update and gated (:func:`gate_channels`) on its own innovation; the update then uses every channel that
passed (:mod:`oilwatch.estimator.kernels`). One health record per probe:

* **dead**: non-finite for ``dead_samples`` in a row while other channels are finite (a single NaN only drops
  that channel from that sample; a sample with no finite channel is a missing sample, not four dead probes);
* **stuck**: the reading unchanged (within ``stuck_tolerance_m``) for ``stuck_samples`` in a row: a live probe
  with micrometre noise never repeats itself for long. A reading repeated twice in a row is already dropped
  from the update (a held value carries no measurement), so a stuck probe never feeds the filter;
* **out of range**: ``|reading| > range_m`` (the radial clearance plus a margin for offsets and runout): the
  journal cannot be there, so the sample is physically impossible and the channel is flagged at once;
* **rejected**: the channel failed the gate ``rejected_samples`` times in a row on its own.

A faulty channel is excluded until it has looked healthy (finite, in range, moving, inside the gate) for
``recover_samples`` in a row; it is never forced back in.

The gate is per channel and scale-adaptive, so that it cannot select samples by orbit phase. A channel's
standardized innovation ``r_i = y_i / sqrt(S_ii)`` is rejected when ``r_i^2 > g max(1, w_i)``, ``g`` the
chi-square(1) quantile of the configured tail probability and ``w_i`` a fading-memory average of the
channel's accepted ``r_i^2`` (time constant ``power_window`` samples; Bar-Shalom, Li & Kirubarajan,
"Estimation with Applications to Tracking and Navigation", 2001, sec. 5.4.2 and 11.2.2). A model mismatch that
makes the innovation a large 1x sinusoid raises ``w_i`` to the sinusoid's mean square within a few
revolutions, and a sinusoid's peak is at most twice its mean square: no phase of the orbit is singled out.
A glitch on one probe exceeds its own recent scale and is rejected. When two or more channels are rejected in
the same sample the cause is common (the machine changed, not two probes at once): no channel is counted
towards a fault and their scales grow by the clipped value ``g max(1, w_i)``, which widens the gate
geometrically until the filter has caught up, in place of the forced acceptance this replaces.
"""

from __future__ import annotations

import numpy as np
from numba import njit

OK, DEAD, STUCK, OUT_OF_RANGE, REJECTED = 0, 1, 2, 3, 4
"""Probe status codes (``probe_status`` outputs)."""

STATUS_NAMES = ("ok", "dead", "stuck", "out of range", "rejected")

# columns of the integer health array (4, 6)
STATUS, DEAD_COUNT, STUCK_COUNT, REJECT_COUNT, GOOD_COUNT, PREVIOUS_ACCEPTED = range(6)
# columns of the float health array (4, 4)
LAST_VALUE, POWER, BIAS, LAST_ACCEPTED = range(4)

# channel settings array
(
    GATE,
    RANGE,
    DEAD_SAMPLES,
    STUCK_SAMPLES,
    STUCK_TOLERANCE,
    REJECTED_SAMPLES,
    RECOVER_SAMPLES,
    POWER_ALPHA,
    BIAS_ALPHA,
) = range(9)
N_CHANNEL_SETTINGS = 9


def new_health() -> tuple[np.ndarray, np.ndarray]:
    """Fresh health arrays: integer (4, 6) and float (4, 4) (see the column constants)."""
    integers = np.zeros((4, 6), dtype=np.int64)
    floats = np.zeros((4, 4))
    floats[:, LAST_VALUE] = np.nan
    floats[:, POWER] = 1.0
    return integers, floats


@njit(cache=True)
def screen_channels(
    displacement: np.ndarray, health: np.ndarray, values: np.ndarray, settings: np.ndarray, usable: np.ndarray
) -> None:
    """Update the dead / stuck / range records from this sample; ``usable`` (4,) bool: may enter the gate.

    A sample with no finite channel at all is a missing sample (a gap the host predicts through, a lost
    frame), not evidence against any one probe: it does not count towards ``dead``.
    """
    missing = True
    for i in range(4):
        if np.isfinite(displacement[i]):
            missing = False
    for i in range(4):
        z = displacement[i]
        finite = np.isfinite(z)
        if finite:
            health[i, DEAD_COUNT] = 0
            if abs(z - values[i, LAST_VALUE]) <= settings[STUCK_TOLERANCE]:
                health[i, STUCK_COUNT] += 1
            else:
                health[i, STUCK_COUNT] = 0
            values[i, LAST_VALUE] = z
        elif not missing:
            health[i, DEAD_COUNT] += 1
        in_range = finite and abs(z) <= settings[RANGE]
        stuck = health[i, STUCK_COUNT] >= settings[STUCK_SAMPLES]
        if health[i, STATUS] == OK:
            if health[i, DEAD_COUNT] >= settings[DEAD_SAMPLES]:
                health[i, STATUS] = DEAD
            elif stuck:
                health[i, STATUS] = STUCK
            elif finite and not in_range:
                health[i, STATUS] = OUT_OF_RANGE
            if health[i, STATUS] != OK:
                health[i, GOOD_COUNT] = 0
        # a repeated reading is held, not measured: it is dropped at once, the fault flagged after the window
        usable[i] = in_range and health[i, STUCK_COUNT] < 2
        if health[i, STATUS] != OK and not usable[i]:
            health[i, GOOD_COUNT] = 0


@njit(cache=True)
def gate_channels(
    innovation: np.ndarray,
    variance: np.ndarray,
    health: np.ndarray,
    values: np.ndarray,
    settings: np.ndarray,
    usable: np.ndarray,
    accepted: np.ndarray,
) -> int:
    """Gate each usable channel on its standardized innovation; update faults, scales and recoveries.

    innovation, variance : (4,) y_i and S_ii. ``accepted`` (4,) bool out: the channel enters the update.
    Returns the number of usable healthy channels the gate rejected.
    """
    gate = settings[GATE]
    rejected = np.zeros(4, dtype=np.bool_)
    count = 0
    for i in range(4):
        accepted[i] = False
        if not usable[i]:
            continue
        r2 = innovation[i] * innovation[i] / variance[i]
        inside = r2 <= gate * max(1.0, values[i, POWER])
        if health[i, STATUS] != OK:
            health[i, GOOD_COUNT] = health[i, GOOD_COUNT] + 1 if inside else 0
            if health[i, GOOD_COUNT] >= settings[RECOVER_SAMPLES]:
                health[i, STATUS] = OK
                health[i, REJECT_COUNT] = 0
                health[i, GOOD_COUNT] = 0
            continue
        if inside:
            accepted[i] = True
            values[i, POWER] += settings[POWER_ALPHA] * (r2 - values[i, POWER])
            values[i, BIAS] += settings[BIAS_ALPHA] * (innovation[i] / np.sqrt(variance[i]) - values[i, BIAS])
        else:
            rejected[i] = True
            count += 1
    for i in range(4):
        if not rejected[i]:
            if accepted[i]:
                health[i, REJECT_COUNT] = 0
            continue
        if count >= 2:  # common cause: the model, not the probes; widen the gates
            values[i, POWER] += settings[POWER_ALPHA] * (gate * max(1.0, values[i, POWER]) - values[i, POWER])
        else:
            health[i, REJECT_COUNT] += 1
            if health[i, REJECT_COUNT] >= settings[REJECTED_SAMPLES]:
                health[i, STATUS] = REJECTED
                health[i, GOOD_COUNT] = 0
    return count
