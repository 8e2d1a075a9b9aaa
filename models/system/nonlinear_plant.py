"""The high-fidelity plant: the rotor on two transient p-theta films, with flowrate faults and noisy probes.

The same interface as :class:`oilwatch.models.system.plant.RotorBearingPlant` (``step``, ``current_sample``,
``flowrates``, ``snapshot``/``restore``, ``set_period``) so that a caller chooses the film model by
name (:func:`make_plant`, ``film_model`` = "linearized-table" or "transient-film"). The truth then
contains what the estimator's linearized model leaves out: the films' own dynamics (content transport
in the cavitated zone, the lag of a starving film after a supply change) and their nonlinearity.

Cost: every output period runs ``substeps`` implicit steps of both films (see
:mod:`oilwatch.models.system.nonlinear`), each a few film steps of the rotor-film coupling: far slower than
real time (:data:`TRANSIENT_PLANT_MESH`, ``benchmarks/transient_film.py`` and the README give the figures).
"""

from __future__ import annotations

import copy

import numpy as np

from ..machine import Machine
from ..rotor.assembly import Rotor
from ..validation import InputError, require_non_negative, require_positive
from .measurement import film_state
from .nonlinear_studies import orbit_setup
from .plant import PlantSample

FILM_MODELS = ("linearized-table", "transient-film")
TRANSIENT_SUBSTEPS = 3
"""Implicit steps per 1 ms output period (0.33 ms: 40 per revolution at 75 Hz). Against 5 substeps (67 per
revolution), 0.2 s from the orbit start on the 60 x 16 mesh: 1x amplitudes within 1.1 % and phases within
0.7 deg, static positions within 0.02 um, at 0.78 of the cost (2 substeps: 1.5 %, 1.3 deg, 0.6)."""
PLANT_POSITION_TOLERANCE_M = 1e-9
"""The plant's rotor-film coupling accepts a step when the position update is below this: 1/1000 of the
1 um probe noise (the studies use 1e-10 m)."""
PLANT_FILM_OPTIONS = {"residual_tolerance": 1e-8, "mass_tolerance": 1e-7}
"""The plant's film sweeps stop at residuals of 1e-8 of U c L / 2 and a mass balance of 1e-7 of the
supply per step (the studies: 1e-11 and 1e-10). Below the coupling's own noise floor: a position update
of 1e-9 m already moves the side leakage by ~1e-3 of the supply."""


class TransientFilmPlant:
    """Rotor on transient films; flowrates from ``schedules`` (time -> m^3/s) or held inputs.

    Parameters: ``machine``; ``mesh`` of the films; ``dt_s`` output period [s]; ``schedules`` one
    flowrate schedule per bearing or None (inputs, ``initial_flowrates_m3_s``); ``noise_std_m``;
    ``seed``. The plant starts on the 1x orbit of its initial flowrates (the frequency-dependent linear
    orbit, from which the films' own start transient decays in a few tenths of a second).
    """

    def __init__(
        self,
        machine: Machine,
        mesh,
        dt_s: float,
        schedules,
        noise_std_m: float,
        seed: int,
        initial_flowrates_m3_s=None,
        substeps: int = TRANSIENT_SUBSTEPS,
        start_time_s: float = 0.0,
    ):
        self.dt_s = require_positive("dt_s", dt_s, "s")
        self.noise_std_m = require_non_negative("noise std", noise_std_m, "m")
        self.schedules = schedules
        if schedules is None and initial_flowrates_m3_s is None:
            raise InputError("initial_flowrates_m3_s is required when the flowrates are inputs")
        self._inputs = tuple(initial_flowrates_m3_s) if initial_flowrates_m3_s is not None else None
        self.substeps = int(substeps)
        q0 = self.flowrates(start_time_s)
        if abs(q0[0] - q0[1]) > 1e-9 * q0[0]:
            raise InputError("the transient-film plant starts from equal flowrates in both bearings")
        self.sim, _, start, _ = orbit_setup(
            machine,
            mesh,
            q0[0],
            dt_s=self.dt_s / self.substeps,
            position_tolerance_m=PLANT_POSITION_TOLERANCE_M,
            film_options=PLANT_FILM_OPTIONS,
        )
        self._clearance_m = np.array([bearing.clearance_m for bearing in machine.bearings])
        start.time_s = start_time_s
        self.state = start
        self.rng = np.random.default_rng(seed)
        self.time_s = start_time_s
        self._current = np.array(q0)

    def flowrates(self, time_s: float) -> tuple[float, float]:
        """True supply flowrates [m^3/s] at ``time_s``."""
        if self.schedules is None:
            return self._inputs
        return tuple(float(s(np.array([time_s]))[0]) for s in self.schedules)

    def step(self, inputs_m3_s=None) -> PlantSample:
        """Advance one output period (inputs, if the flowrates are inputs, hold over it)."""
        if self.schedules is None:
            if inputs_m3_s is None:
                raise InputError("flowrate inputs are required when the flowrates are inputs")
            self._inputs = (float(inputs_m3_s[0]), float(inputs_m3_s[1]))
        for _ in range(self.substeps):
            q = self.flowrates(self.state.time_s + self.sim.h)
            self.state = self.sim.step(self.state, q)
        self._current = np.array(q)
        self.time_s = self.state.time_s
        return self.current_sample()

    def current_sample(self) -> PlantSample:
        """The sample at the current time (a fresh noise draw)."""
        true = self.sim.selector @ self.state.r
        measured = true + self.noise_std_m * self.rng.standard_normal(true.size)
        ratio, thickness = film_state(true, self._clearance_m)
        return PlantSample(true, measured, self._current.copy(), ratio, thickness)

    @property
    def rotor_angle_rad(self) -> float:
        """The rotor's angle from the keyphasor mark [rad]: Omega t at the fixed speed (the unbalance
        load is Re(F_u exp(i Omega t)))."""
        return self.sim.omega * self.time_s

    def set_period(self, dt_s: float) -> None:
        """The period is fixed at instantiation (the films' step is part of their state)."""
        if abs(dt_s - self.dt_s) > 1e-12 * self.dt_s:
            raise InputError(f"step size: the transient-film plant runs at {self.dt_s:g} s, got {dt_s:g} s")

    def snapshot(self) -> dict:
        """Everything that determines future samples."""
        return {
            "state": copy.deepcopy(self.state),
            "inputs": self._inputs,
            "rng": self.rng.bit_generator.state,
            "time_s": self.time_s,
            "current": self._current.copy(),
        }

    def restore(self, snapshot: dict) -> None:
        """Return to a :meth:`snapshot`."""
        self.state = copy.deepcopy(snapshot["state"])
        self._inputs = snapshot["inputs"]
        self.rng.bit_generator.state = snapshot["rng"]
        self.time_s = snapshot["time_s"]
        self._current = snapshot["current"].copy()


def check_film_model(name: str) -> str:
    """``name`` if it is one of :data:`FILM_MODELS`, else a one-line error."""
    if name not in FILM_MODELS:
        raise InputError(f"film_model must be one of {', '.join(FILM_MODELS)}; got {name!r}")
    return name


TRANSIENT_PLANT_MESH = (60, 16)
"""Film mesh of the high-fidelity plant: the mesh of the committed direct simulations (the 1x orbits of
the frequency-dependent model agree with it within 1.1 % and 1.7 deg). Not mesh-converged: its linear
1x orbits are 5 %/10 deg (100 %) and 19 %/10 deg (75 %) from 240 x 72's. Cost per 1 ms sample, one core,
load 10-20: 22.5 ms CPU (sweeps, mid-plane half, 469 volumes; a 20 s record: 7.5 min of CPU for the
plant); 120 x 36 (multigrid, 2098 volumes) 90.6 ms (30 min for 20 s), hence this mesh."""


NEVER_S = 1e9
"""The FMU's start value for "no fault / no change" times [s]."""


def _refuse_chain_options(options: dict) -> None:
    from .measurement import MeasurementChain

    chain, change = options.get("chain"), options.get("unbalance_change")
    ideal = MeasurementChain().probes[0]
    # Without a fault its start time and glitch do not matter (the FMU's "never" is NEVER_S, not inf).
    errors = ("zero_offset_m", "sensitivity_error", "runout_1x_m", "runout_2x_m", "fault")
    if chain is not None and (
        any(getattr(p, name) != getattr(ideal, name) for p in chain.probes for name in errors)
        or chain.mounting_angle_rad != 0.0
    ):
        raise InputError("film_model = transient-film has ideal probes: leave the probe parameters at 0")
    if change is not None and change.time_s < NEVER_S:
        raise InputError("film_model = transient-film has no unbalance change: leave unbalance_change_time_s")
    if options.get("oil") is not None or options.get("viscosity_factor", 1.0) != 1.0:
        raise InputError(
            "film_model = transient-film runs with bearing_table = 0 and viscosity_factor = 1 only"
        )


def make_plant(
    film_model: str,
    system,
    machine: Machine,
    dt_s: float,
    schedules,
    noise_std_m: float,
    seed: int,
    initial_flowrates_m3_s=None,
    start_time_s: float = 0.0,
    **chain_options,
):
    """The plant of ``film_model``: the linear :class:`RotorBearingPlant` on ``system`` or the
    :class:`TransientFilmPlant` of ``machine`` (nominal speed and unbalance of the machine file).

    chain_options: the linear plant's measurement chain, unbalance change and operating-point options
    (:class:`RotorBearingPlant`); the transient-film plant has ideal probes and no operating-point inputs, so
    it refuses any of them that is not at its default."""
    from ..bearing.grid import Mesh
    from .plant import RotorBearingPlant

    if check_film_model(film_model) == "linearized-table":
        return RotorBearingPlant(
            system,
            dt_s,
            schedules,
            noise_std_m,
            seed,
            initial_flowrates_m3_s=initial_flowrates_m3_s,
            start_time_s=start_time_s,
            **chain_options,
        )
    _refuse_chain_options(chain_options)
    if abs(system.speed_hz - machine.nominal_speed_hz) > 1e-9 * machine.nominal_speed_hz:
        raise InputError(
            f"speed_hz = {system.speed_hz:g} Hz: film_model = transient-film runs at the machine's nominal "
            f"speed {machine.nominal_speed_hz:g} Hz only"
        )
    default = Rotor.from_machine(machine)
    if not (
        np.isclose(system.unbalance_moment_kg_m, default.unbalance_moment_kg_m, rtol=1e-9)
        and np.isclose(system.unbalance_phase_rad, default.unbalance_phase_rad, atol=1e-12)
    ):
        raise InputError("unbalance: film_model = transient-film runs with the machine file's unbalance only")
    return TransientFilmPlant(
        machine,
        Mesh(*TRANSIENT_PLANT_MESH),
        dt_s,
        schedules,
        noise_std_m,
        seed,
        initial_flowrates_m3_s=initial_flowrates_m3_s,
        start_time_s=start_time_s,
    )
