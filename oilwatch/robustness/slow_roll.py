"""A slow-roll record from the plant's measurement chain, and the runout vectors fitted to it.

At slow roll the field measures each probe's runout: the 1x and 2x vectors a probe reads when the shaft turns
so slowly that its dynamic response is negligible (API 670; Bently Nevada's slow-roll compensation). This
module produces that record honestly with the plant's own measurement chain
(:class:`oilwatch.models.system.measurement.MeasurementChain`: the same probes, runout, sensitivity errors,
offsets and noise as the run), on a shaft assumed at rest in its bearings at slow roll:

* speed ``SLOW_ROLL_FRACTION`` (5 %) of nominal, 60 s by default (about 225 revolutions for the turbine);
* true journal position constant at 70 % of the clearance below the centre (a slow-roll journal sits low
  in a lightly loaded bearing; the fit's constant term takes it whatever it is);
* the 1x dynamic response taken as zero. Justification: the unbalance force scales with the speed squared,
  so at 5 % it is 1/400 of the running force (1.97 N for the turbine's 3540 g mm at 3.75 Hz); against the
  bearing-and-shaft static stiffness (order 1e7-1e8 N/m) that moves the journal by 0.02-0.2 nm, far below
  the runout (um) and the fit's own std (about 0.01 um at 1 um noise over 60 s).

:func:`oilwatch.estimator.runout.fit_slow_roll` then fits the vectors with their stds.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from oilwatch.estimator.runout import SlowRollVectors, fit_slow_roll
from oilwatch.models.system.measurement import MeasurementChain

SLOW_ROLL_FRACTION = 0.05
REST_ECCENTRICITY = 0.7


def slow_roll_record(
    chain: MeasurementChain,
    clearances_m: Sequence[float],
    nominal_speed_hz: float,
    duration_s: float,
    dt_s: float,
    seed: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(times (K,) [s], probe signals (K, 4) [m], rotor angle (K,) [rad]) at slow roll (module docstring), for
    bearings of radial clearances ``clearances_m`` (bearing 1 first). Probe faults are not played: a slow-roll
    record is taken with healthy probes."""
    healthy = dataclasses.replace(
        chain, probes=tuple(dataclasses.replace(p, fault="none") for p in chain.probes)
    )
    omega = 2.0 * math.pi * SLOW_ROLL_FRACTION * nominal_speed_hz
    rest = np.array([[0.0, -REST_ECCENTRICITY * c] for c in clearances_m]).ravel()
    rng = np.random.default_rng([seed, 51])
    held = np.zeros(4)
    times = dt_s * np.arange(1, round(duration_s / dt_s) + 1)
    signals = np.array([healthy.measure(rest, omega * t, t, rng, held) for t in times])
    return times, signals, omega * times


def slow_roll_vectors(
    chain: MeasurementChain,
    clearances_m: Sequence[float],
    nominal_speed_hz: float,
    duration_s: float,
    dt_s: float,
    seed: int,
) -> SlowRollVectors:
    """The runout vectors fitted to :func:`slow_roll_record`."""
    return fit_slow_roll(*slow_roll_record(chain, clearances_m, nominal_speed_hz, duration_s, dt_s, seed))
