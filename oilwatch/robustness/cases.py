"""The discrepancies between a real machine and the estimator's model that ``oilwatch robustness`` plays.

Each case changes the plant (its unbalance) or the probe signals (offsets, runout, mounting angle, faults)
and never the estimator's model; the estimator gets only what a user would configure (the probes' mounting
angle, the offsets' prior std). Signal discrepancies are injected into the plant's measured positions here,
in-process, until the plant FMU carries its own measurement chain.

The probes read along their own axes: with a mounting angle a, probe X reads ``cos a x + sin a y`` and probe
Y ``-sin a x + cos a y`` (:func:`estimator.measurement.probe_rotation`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from estimator.measurement import probe_rotation

OFFSET_RANGE_M = 25e-6
"""Probe zero offsets are drawn uniformly from +-25 um (ordinary: the bearing centre is known only from the
cold-rest position and a clearance with a tolerance)."""

FAULT_CHANNEL = 1
"""Probe faults are put on y1, the channel that carries most of bearing 1's information."""

Injection = Callable[[np.ndarray, np.ndarray, np.random.Generator, float], np.ndarray]
"""``(measured (K, 4) [m], times (K,) [s], rng, omega [rad/s]) -> signals (K, 4)``."""


@dataclass(frozen=True)
class Case:
    """One discrepancy. ``unbalance``: (moment factor, phase shift [deg]) of the plant's unbalance;
    ``inject``: what the measurement chain does to the positions; ``ekf``: estimator settings a user would
    give (EKFConfig fields); ``probe_fault``: the faulty channel the estimator must flag, if any;
    ``unbalance_change``: (moment factor, phase shift [deg]) the unbalance switches to at half the record;
    ``offsets``: the run's probe offsets (:func:`probe_offsets`) are on the probes, drifting by ``drift_m``
    over the record; ``baseline``: the estimator is primed with ``oilwatch baseline`` on another record at
    100/100 % with the same offsets (before the drift)."""

    name: str
    description: str
    unbalance: tuple[float, float] = (1.0, 0.0)
    inject: Injection | None = None
    ekf: dict = field(default_factory=dict)
    probe_fault: int | None = None
    unbalance_change: tuple[float, float] | None = None
    offsets: bool = False
    drift_m: float = 0.0
    baseline: bool = False


def probe_offsets(seed: int) -> np.ndarray:
    """(4,) the probe zero offsets of a run [m], the same for every offset case of that run's seed."""
    return np.random.default_rng([seed, 25]).uniform(-OFFSET_RANGE_M, OFFSET_RANGE_M, 4)


def apply_offsets(data: np.ndarray, times: np.ndarray, seed: int, drift_m: float = 0.0) -> np.ndarray:
    """The run's probe offsets, plus a drift growing linearly to ``drift_m`` (a random sign per probe)."""
    signs = np.where(np.random.default_rng([seed, 3]).uniform(size=4) < 0.5, -1.0, 1.0)
    return data + probe_offsets(seed)[None, :] + drift_m * signs[None, :] * (times / times[-1])[:, None]


def _runout(data, times, rng, omega):
    phases = rng.uniform(0.0, 2.0 * np.pi, (2, 4))
    once = 2e-6 * np.cos(omega * times[:, None] + phases[0][None, :])
    twice = 1e-6 * np.cos(2.0 * omega * times[:, None] + phases[1][None, :])
    return data + once + twice


def _api670(data, times, rng, omega):
    return data @ probe_rotation(np.radians(45.0)).T


def _fault(kind: str) -> Injection:
    def inject(data, times, rng, omega):
        out = data.copy()
        duration = times[-1]
        later = times >= duration / 6.0  # 10 s of 60 s
        burst = (times >= duration / 3.0) & (times < duration / 3.0 + (0.1 if kind == "glitch" else 0.5))
        channel = out[:, FAULT_CHANNEL]
        if kind == "dead":
            channel[later] = np.nan
        elif kind == "stuck":
            channel[later] = channel[np.flatnonzero(later)[0] - 1]
        elif kind == "glitch":
            channel[burst] += 500e-6
        else:
            channel[burst] = 1.0
        return out

    return inject


CASES: tuple[Case, ...] = (
    Case("none", "plant and probes as the model"),
    Case("offsets", "probe zero offsets drawn from +-25 um, no baseline", offsets=True),
    Case(
        "offsets-baseline",
        "the same offsets, baseline from another 100/100 record",
        offsets=True,
        baseline=True,
    ),
    Case(
        "offsets-drift",
        "the same offsets, baseline, then 3 um of drift over the record",
        offsets=True,
        drift_m=3e-6,
        baseline=True,
    ),
    Case("unbalance-x0.5", "unbalance moment x0.5", unbalance=(0.5, 0.0)),
    Case("unbalance-x3", "unbalance moment x3", unbalance=(3.0, 0.0)),
    Case("phase-90", "unbalance phase +90 deg", unbalance=(1.0, 90.0)),
    Case("phase-180", "unbalance phase +180 deg", unbalance=(1.0, 180.0)),
    Case("phase-270", "unbalance phase +270 deg", unbalance=(1.0, 270.0)),
    Case("unbalance-change", "unbalance x2 and +120 deg at half the record", unbalance_change=(2.0, 120.0)),
    Case("runout", "runout 2 um at 1x and 1 um at 2x on every probe", inject=_runout),
    Case(
        "api670",
        "probes at 45 deg either side of the top (API 670), angle given",
        inject=_api670,
        ekf={"probe_angle_deg": 45.0},
    ),
    Case("dead", "probe y1 dead (NaN) from 1/6 of the record", inject=_fault("dead"), probe_fault=1),
    Case("stuck", "probe y1 stuck from 1/6 of the record", inject=_fault("stuck"), probe_fault=1),
    Case("glitch", "probe y1 +500 um for 0.1 s at 1/3 of the record", inject=_fault("glitch"), probe_fault=1),
    Case(
        "huge", "probe y1 reads 1e6 um for 0.5 s at 1/3 of the record", inject=_fault("huge"), probe_fault=1
    ),
)
"""The issue's list as far as the plant supports it today (no viscosity, temperature, speed or baseline cases
yet: they need the plant's measurement chain and operating-condition inputs)."""


def case_by_name(name: str) -> Case:
    """The case called ``name`` (InputError naming the choices otherwise)."""
    from models.validation import InputError

    for case in CASES:
        if case.name == name:
            return case
    raise InputError(f"--cases: unknown case {name!r}; choose from {', '.join(c.name for c in CASES)}")
