"""The plant's measurement chain: what four proximity probes on a real machine report.

From the true shaft position r_b = (x, y) in each bearing (from the bearing centre, x horizontal, y up) each
probe p of bearing b reports, in this order:

1. the projection on its axis n_p: the bearing's X probe points at ``mounting_angle_rad`` from horizontal
   (0: horizontal / vertical pair; pi/4: the API 670 pair, X 45 deg right and Y 45 deg left of top dead
   centre), its Y probe 90 deg further counter-clockwise;
2. plus the runout of the shaft surface under it (mechanical and electrical runout, Bently's "glitch"
   of slow-roll vectors): a_1 cos(theta + phi_1) + a_2 cos(2 theta + phi_2), theta the rotor angle from the
   keyphasor (Omega t at constant speed);
3. times 1 + the sensitivity error (scale factor off its nominal 7.87 V/mm);
4. plus the zero offset (the bearing centre is known only to the clearance's tolerance), drifting at
   ``zero_drift_m_s`` from t = 0 (electronics and thermal drift);
5. plus white noise (std ``noise_std_m``);
6. then its fault: ``dead`` from ``fault_time_s`` on (NaN, an open circuit), ``stuck`` from then on at its
   last value before that time, or ``glitch``: + ``glitch_m`` during [fault_time_s, fault_time_s +
   glitch_duration_s).

With every parameter at its default the chain is the true position plus noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from functools import cached_property

import numpy as np

from ..validation import InputError, require_finite, require_in_range, require_non_negative

PROBE_NAMES = ("x1", "y1", "x2", "y2")
FAULT_KINDS = ("none", "dead", "stuck", "glitch")


def _meta(unit: str, low: float, high: float, description: str) -> dict:
    return {"unit": unit, "range": (low, high), "description": description}


def probe_axes(mounting_angle_rad: float) -> np.ndarray:
    """(2, 2) the unit vectors in a bearing's (x, y) along which its X probe (row 0) and its Y probe (row 1)
    read, the pair mounted at ``mounting_angle_rad`` counter-clockwise from +x."""
    a = mounting_angle_rad
    return np.array([[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]])


@dataclass(frozen=True)
class ProbeErrors:
    """The imperfections of one probe (SI; the unit, range and description of each field in its metadata)."""

    zero_offset_m: float = field(
        default=0.0, metadata=_meta("m", -500e-6, 500e-6, "zero offset added to the reading")
    )
    zero_drift_m_s: float = field(
        default=0.0,
        metadata=_meta("m/s", -1e-6, 1e-6, "drift rate of the zero offset (offset + rate x time)"),
    )
    sensitivity_error: float = field(
        default=0.0, metadata=_meta("1", -0.5, 0.5, "relative scale-factor error: reading x (1 + error)")
    )
    runout_1x_m: float = field(default=0.0, metadata=_meta("m", 0.0, 100e-6, "1x runout amplitude"))
    runout_1x_phase_rad: float = field(
        default=0.0, metadata=_meta("rad", -2 * math.pi, 2 * math.pi, "1x runout phase from the keyphasor")
    )
    runout_2x_m: float = field(default=0.0, metadata=_meta("m", 0.0, 100e-6, "2x runout amplitude"))
    runout_2x_phase_rad: float = field(
        default=0.0, metadata=_meta("rad", -2 * math.pi, 2 * math.pi, "2x runout phase from the keyphasor")
    )
    fault: str = field(default="none", metadata=_meta("", 0, 3, "fault: none, dead (NaN), stuck, glitch"))
    fault_time_s: float = field(default=math.inf, metadata=_meta("s", 0.0, math.inf, "time the fault starts"))
    glitch_m: float = field(default=0.0, metadata=_meta("m", -1.0, 1.0, "size of a glitch fault"))
    glitch_duration_s: float = field(
        default=0.0, metadata=_meta("s", 0.0, math.inf, "length of a glitch fault")
    )

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name == "fault":
                continue
            low, high = f.metadata["range"]
            value = getattr(self, f.name)
            if f.name == "fault_time_s" and value == math.inf:
                continue
            require_in_range(f.name, value, low, high, f.metadata["unit"])
        if self.fault not in FAULT_KINDS:
            raise InputError(f"probe fault must be one of {FAULT_KINDS}, got {self.fault!r}")


@dataclass(frozen=True)
class MeasurementChain:
    """Four probes (x1, y1, x2, y2) with their errors, the mounting angle and the noise."""

    probes: tuple[ProbeErrors, ...] = (ProbeErrors(),) * 4
    mounting_angle_rad: float = 0.0
    noise_std_m: float = 0.0

    def __post_init__(self) -> None:
        if len(self.probes) != len(PROBE_NAMES):
            raise InputError(f"a measurement chain has {len(PROBE_NAMES)} probes, got {len(self.probes)}")
        require_in_range("probe mounting angle", self.mounting_angle_rad, -math.pi, math.pi, "rad")
        require_non_negative("noise std", self.noise_std_m, "m")

    @cached_property
    def projection(self) -> np.ndarray:
        """(4, 4) map from true (x1, y1, x2, y2) to the probe axes' readings."""
        block = probe_axes(self.mounting_angle_rad)
        out = np.zeros((4, 4))
        out[:2, :2] = block
        out[2:, 2:] = block
        return out

    def probe_readings(self, true_m: np.ndarray, rotor_angle_rad: float) -> np.ndarray:
        """Steps 1-4 (no noise, no fault): the readings (4,) [m] of true positions (4,) [m]."""
        reading = self.projection @ np.asarray(true_m, dtype=float)
        out = np.empty(4)
        for k, p in enumerate(self.probes):
            runout = p.runout_1x_m * math.cos(rotor_angle_rad + p.runout_1x_phase_rad)
            runout += p.runout_2x_m * math.cos(2.0 * rotor_angle_rad + p.runout_2x_phase_rad)
            out[k] = (reading[k] + runout) * (1.0 + p.sensitivity_error) + p.zero_offset_m
        return out

    def drift_m(self, time_s: float) -> np.ndarray:
        """(4,) the offsets' drift at ``time_s`` [m] (rate x time)."""
        return np.array([p.zero_drift_m_s * time_s for p in self.probes])

    def measure(
        self,
        true_m: np.ndarray,
        rotor_angle_rad: float,
        time_s: float,
        rng: np.random.Generator,
        held: np.ndarray,
    ) -> np.ndarray:
        """The measured signals (4,) [m] at ``time_s``; ``held`` (4,) keeps each probe's last output
        (updated in place: it is what a stuck probe repeats)."""
        t = require_finite("time", time_s)
        noise = self.noise_std_m * rng.standard_normal(4)
        measured = self.probe_readings(true_m, rotor_angle_rad) + noise + self.drift_m(t)
        for k, p in enumerate(self.probes):
            if p.fault == "none" or t < p.fault_time_s:
                held[k] = measured[k]
            elif p.fault == "dead":
                measured[k] = math.nan
            elif p.fault == "stuck":
                measured[k] = held[k]
            elif t < p.fault_time_s + p.glitch_duration_s:  # glitch
                measured[k] += p.glitch_m
        return measured


@dataclass(frozen=True)
class UnbalanceChange:
    """A sudden unbalance change (a blade loss): from ``time_s`` on, ``moment_kg_m`` at ``phase_rad``."""

    time_s: float = math.inf
    moment_kg_m: float = 0.0
    phase_rad: float = 0.0

    def __post_init__(self) -> None:
        require_non_negative("unbalance change moment", self.moment_kg_m, "kg m")
        require_finite("unbalance change phase", self.phase_rad)


def film_state(true_m: np.ndarray, clearance_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eccentricity ratio (2,) and minimum film thickness c (1 - eps) (2,) [m] of both bearings from the true
    journal positions (x1, y1, x2, y2) [m] and the radial clearances (2,) [m]."""
    xy = np.asarray(true_m, dtype=float).reshape(2, 2)
    ratio = np.hypot(xy[:, 0], xy[:, 1]) / clearance_m
    return ratio, clearance_m * (1.0 - ratio)
