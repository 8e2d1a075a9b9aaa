"""The simulated machine: the rotor-bearing system integrated in time with supply-flowrate faults.

``RotorBearingPlant`` produces what a real machine's proximity probes would measure while its oil supply
changes: the true shaft position in each bearing (Newmark integration of the full model, not the estimator's
discrete map), the same plus seeded white measurement noise, and the true flowrates. The flowrates follow a
sigmoid schedule per bearing (``fault``) or external inputs held over each step.

The plant starts in the steady unbalance orbit of its initial flowrates: a machine running steadily before
its fault. Its probes form a measurement chain (``measurement``: mounting angle, zero offsets, sensitivity
errors, runout, faults, noise); the true positions and the bearings' instantaneous film state (eccentricity
ratio, minimum film thickness) are output beside the measured signals. An unbalance change (a blade loss)
takes effect from the first sampling instant at or after its time.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..oil import Oil
from ..validation import InputError, require_finite, require_in_range, require_non_negative, require_positive
from .fault import SigmoidFlowrate
from .measurement import MeasurementChain, UnbalanceChange, film_state
from .newmark import NewmarkIntegrator
from .operating_point import set_operating_conditions
from .rotor_bearing import RotorBearingSystem

DEFAULT_SUBSTEPS = 8
"""Trapezoidal sub-steps per sampling period: 0.2 % orbit error at 75 Hz and 1 ms (see the tests)."""


@dataclass(frozen=True)
class PlantSample:
    """One output sample (SI): true and measured (x1, y1, x2, y2) [m], the true flowrates (2,) [m^3/s], and
    per bearing the eccentricity ratio (2,) [-] and minimum film thickness (2,) [m] of the true position."""

    true_position_m: np.ndarray
    measured_position_m: np.ndarray
    flowrate_m3_s: np.ndarray
    eccentricity_ratio: np.ndarray
    min_film_thickness_m: np.ndarray


class RotorBearingPlant:
    """Time simulation of the rotor-bearing system with flowrate faults and noisy position probes.

    Parameters
    ----------
    system : the rotor-bearing system (normally the full model).
    dt_s : sampling period [s].
    schedules : one flowrate schedule per bearing (``time_s -> m^3/s``), e.g. :class:`SigmoidFlowrate`;
        ``None`` makes the flowrates external inputs (see :meth:`step`).
    noise_std_m : std of the white measurement noise on each probe [m].
    seed : seed of the noise generator (numpy PCG64).
    initial_flowrates_m3_s : the flowrates before the first step, when ``schedules`` is None.
    substeps : trapezoidal sub-steps per period.
    start_time_s : time of the initial state [s].
    chain : the probes' imperfections (default: ideal probes); its noise is ``noise_std_m``.
    unbalance_change : a sudden unbalance change (default: none).
    oil : the machine's oil; with it the oil temperature is an input (:meth:`step`). Speed and temperature
        other than the system's need a system on the dimensionless table (``operating_point``).
    oil_temperature_c : the initial oil supply temperature [degC] (with ``oil``).
    viscosity_factor : the film's true viscosity over the oil's law at the measured temperature (film
        heating, model error) [-].
    """

    def __init__(
        self,
        system: RotorBearingSystem,
        dt_s: float,
        schedules: tuple[SigmoidFlowrate, SigmoidFlowrate] | None,
        noise_std_m: float,
        seed: int,
        initial_flowrates_m3_s: tuple[float, float] | None = None,
        substeps: int = DEFAULT_SUBSTEPS,
        start_time_s: float = 0.0,
        chain: MeasurementChain | None = None,
        unbalance_change: UnbalanceChange | None = None,
        oil: Oil | None = None,
        oil_temperature_c: float | None = None,
        viscosity_factor: float = 1.0,
    ) -> None:
        self.system = system
        self.dt_s = require_positive("dt_s", dt_s, "s")
        self.noise_std_m = require_non_negative("noise std", noise_std_m, "m")
        self.schedules = schedules
        if schedules is None and initial_flowrates_m3_s is None:
            raise InputError("initial_flowrates_m3_s is required when the flowrates are inputs")
        self._inputs = tuple(initial_flowrates_m3_s) if initial_flowrates_m3_s is not None else None
        self.oil = oil
        self.viscosity_factor = require_in_range("viscosity_factor", viscosity_factor, 0.2, 5.0)
        if oil is not None and oil_temperature_c is None:
            raise InputError("oil_temperature_c is required with an oil")
        self.speed_hz = system.speed_hz
        self.oil_temperature_c = oil_temperature_c
        self._set_conditions(self.speed_hz, oil_temperature_c)
        for bearing, name, q in self._flowrate_extremes():
            self._check_flowrate(bearing, name, q)
        self.rng = np.random.default_rng(seed)
        self.chain = dataclasses.replace(chain or MeasurementChain(), noise_std_m=self.noise_std_m)
        self.unbalance_change = unbalance_change or UnbalanceChange()
        self._held = np.zeros(4)
        self._clearance_m = np.array([t.metadata["bearing"]["clearance_m"] for t in system.tables])
        self.substeps = substeps
        self._probe_matrix = system.bearing_maps.reshape(-1, system.n_coordinates)
        start = self.flowrates(start_time_s)
        self.integrator = NewmarkIntegrator(system, self.dt_s, substeps, start)
        self.integrator.reset(start_time_s, start, "steady")
        self.time_s = start_time_s

    def set_period(self, dt_s: float) -> None:
        """Change the sampling period, continuing from the current state."""
        snapshot = self.integrator.snapshot()
        self.dt_s = require_positive("step size", dt_s, "s")
        self.integrator = NewmarkIntegrator(
            self.system, self.dt_s, self.substeps, self.flowrates(self.time_s)
        )
        self.integrator.restore({**snapshot, "propagator_flowrates": None, "propagator": None})

    def _check_flowrate(self, bearing: int, name: str, q_m3_s: float) -> None:
        """InputError unless the flowrate ``name`` of bearing ``bearing`` (from 0) lies in that bearing's own
        coefficient table range."""
        low, high = self.system.bearing_flowrate_bounds_m3_s[bearing]
        if not (np.isfinite(q_m3_s) and low <= q_m3_s <= high):
            raise InputError(
                f"{name} = {q_m3_s * 6e7:.1f} ml/min lies outside bearing {bearing + 1}'s coefficient table "
                f"range [{low * 6e7:.1f}, {high * 6e7:.1f}] ml/min"
            )

    def _flowrate_extremes(self):
        """(bearing from 0, name, flowrate [m^3/s]) of the flowrates checked at the start: the inputs, or each
        schedule's initial and final flowrates."""
        if self.schedules is None:
            return [(b, f"q{b + 1} input", q) for b, q in enumerate(self._inputs)]
        out = []
        for b, schedule in enumerate(self.schedules):
            out += [
                (b, f"q{b + 1} initial", schedule.initial_m3_s),
                (b, f"q{b + 1} final", schedule.final_m3_s),
            ]
        return out

    def flowrates(self, time_s: float) -> tuple[float, float]:
        """True supply flowrates [m^3/s] at ``time_s``."""
        q1, q2 = self.flowrate_schedule(np.array([time_s]))[0]
        return float(q1), float(q2)

    def flowrate_schedule(self, times_s: np.ndarray) -> np.ndarray:
        """True supply flowrates (m, 2) [m^3/s] at the times (m,) [s] (inputs hold over a step)."""
        if self.schedules is None:
            return np.broadcast_to(np.asarray(self._inputs, dtype=float), (len(times_s), 2))
        return np.column_stack([self.schedules[0](times_s), self.schedules[1](times_s)])

    @property
    def viscosity_pa_s(self) -> float:
        """The film viscosity [Pa s] now: viscosity_factor x the oil's at its temperature (or the table's)."""
        return self._viscosity_pa_s

    def _set_conditions(self, speed_hz: float, oil_temperature_c: float | None) -> None:
        """Move the bearing tables and the integrator to a speed [Hz] and oil temperature [degC]."""
        speed = require_positive("speed_hz", speed_hz, "Hz")
        if oil_temperature_c is None:
            nominal = self.system.tables[0].metadata["bearing"]["viscosity_pa_s"]
            viscosity = self.viscosity_factor * nominal
        else:
            if self.oil is None:
                raise InputError(
                    "an oil temperature input needs the machine's oil ([oil] in the machine file)"
                )
            temperature = require_finite("oil_temperature_c", oil_temperature_c)
            viscosity = self.viscosity_factor * self.oil.dynamic_viscosity_pa_s(temperature)
        set_operating_conditions(self.system, speed, viscosity)
        self.speed_hz, self.oil_temperature_c, self._viscosity_pa_s = speed, oil_temperature_c, viscosity
        if hasattr(self, "integrator"):
            self.integrator.set_speed(2.0 * np.pi * speed)

    def step(
        self,
        inputs_m3_s: tuple[float, float] | None = None,
        speed_hz: float | None = None,
        oil_temperature_c: float | None = None,
    ) -> PlantSample:
        """Advance one period; with input-driven flowrates, ``inputs_m3_s`` holds over the period, and so do
        ``speed_hz`` and ``oil_temperature_c`` when given (None: unchanged)."""
        if speed_hz is not None or oil_temperature_c is not None:
            self._set_conditions(
                self.speed_hz if speed_hz is None else speed_hz,
                self.oil_temperature_c if oil_temperature_c is None else oil_temperature_c,
            )
        if self.schedules is None:
            if inputs_m3_s is None:
                raise InputError("flowrate inputs are required when the flowrates are inputs")
            for b, q in enumerate(inputs_m3_s):
                self._check_flowrate(b, f"q{b + 1} input", q)
            self._inputs = (float(inputs_m3_s[0]), float(inputs_m3_s[1]))
        change = self.unbalance_change
        if self.time_s >= change.time_s:
            self.integrator.unbalance_moment = change.moment_kg_m * np.exp(1j * change.phase_rad)
        self.integrator.advance(self.flowrate_schedule)
        self.time_s = self.integrator.time_s
        return self.current_sample()

    def current_sample(self) -> PlantSample:
        """The sample at the current time (a fresh noise draw), without advancing."""
        true = self._probe_matrix @ self.integrator.state[: self.integrator.n]
        angle = self.rotor_angle_rad
        measured = self.chain.measure(true, angle, self.time_s, self.rng, self._held)
        ratio, thickness = film_state(true, self._clearance_m)
        return PlantSample(true, measured, np.array(self.integrator.flowrates_m3_s), ratio, thickness)

    @property
    def rotor_angle_rad(self) -> float:
        """The rotor's angle from the keyphasor mark, the integral of the speed [rad] (what the unbalance
        phase and the runout refer to)."""
        return self.integrator.rotor_angle_rad

    def snapshot(self) -> dict:
        """Everything that determines future samples (integrator, inputs, noise generator)."""
        return {
            "integrator": self.integrator.snapshot(),
            "inputs": self._inputs,
            "rng": self.rng.bit_generator.state,
            "time_s": self.time_s,
            "held": self._held.copy(),
            "conditions": (self.speed_hz, self.oil_temperature_c),
        }

    def restore(self, snapshot: dict) -> None:
        """Return to a :meth:`snapshot` (bit-identical continuation)."""
        self.integrator.restore(snapshot["integrator"])
        self._inputs = snapshot["inputs"]
        self.rng.bit_generator.state = snapshot["rng"]
        self.time_s = snapshot["time_s"]
        self._held = snapshot["held"].copy()
        self._set_conditions(*snapshot["conditions"])


def publish_initial_sample(plant) -> PlantSample:
    """Start a plant (:class:`RotorBearingPlant` or the transient-film plant of
    :mod:`oilwatch.models.system.nonlinear_plant`) as the plant FMU does: publish the sample at the start
    time.

    The FMU's outputs exist from initialization on, so that sample takes the noise generator's first draw
    and the samples of the steps continue the sequence after it. Anything that must see the FMU's noise
    from an in-process plant (the study's ``direct`` case, cross-checked against the FMU path to 0.05
    ml/min) starts its plant here too: the FMU shell and the study share this one call.
    """
    return plant.current_sample()
