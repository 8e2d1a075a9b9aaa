"""A slow coast-down of the plant, as the probes record it: the shaft centreline from speed to slow roll.

A condition-monitoring system keeps the machine's coast-downs (and run-ups); their mean probe signals at each
speed are the shaft-centreline plot. For a coast-down slow enough that the film is quasi-static at every
speed, the journal sits at its static equilibrium: :func:`coast_down_centreline` solves it directly for the
plant's bearings (:class:`oilwatch.models.system.structure.PlantStructure`: clearance, length, load split,
side force) at :data:`NODES` speeds, flooded at the nominal supply pressure, and :func:`coast_down_record`
turns it into a record at 1 kHz: the speed falling exponentially (a drag torque proportional to the speed:
equal time per ln N), the positions interpolated in ln N between the solved speeds, read by a measurement
chain (offsets, scale factors, runout at the rotor angle, noise). What moves the static position relative
to the housing is only the film and the load (its magnitude and direction): the film model's dynamics, the
unbalance, the pedestals and a bow do not.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.interpolate import CubicSpline

from ..bearing.equilibrium import static_equilibrium
from ..bearing.grid import Mesh
from ..bearing.supply import SupplyPressure
from ..machine import Machine
from ..rotor.assembly import Rotor
from ..validation import InputError, require_in_range
from .measurement import MeasurementChain
from .structure import PlantStructure, structural_bearing, structural_machine

NODES = 24
"""Speeds at which the plant's centreline is solved, uniform in ln N (a step of about 16 % from 3 %)."""
PLANT_MESH = Mesh(120, 36)
"""The plant's film mesh: coarser than the production mesh of the estimator's locus (their centrelines
differ by about 5e-4 c), so that the plant is not the estimator's own solve."""
SLOW_ROLL_RANGE = (0.005, 0.3)
"""Lowest speed over the nominal a coast-down may end at."""


def coast_down_centreline(
    machine: Machine, structure: PlantStructure, speeds_hz, oil_temperature_c: float, mesh=None
) -> np.ndarray:
    """(K, 4) the plant's journal positions (x1, y1, x2, y2) [m] relative to the bearing housings at the
    speeds (K,), flooded at nominal supply pressure: each bearing's static equilibrium with the structure's
    clearance, length, load split and side force (the load's magnitude and direction), solved directly
    (:func:`oilwatch.models.bearing.equilibrium.static_equilibrium` on ``mesh``, the production mesh when
    None), at the oil law's viscosity at ``oil_temperature_c``."""
    pressure = machine.lubrication.nominal_supply_pressure_pa
    if not math.isfinite(pressure):
        raise InputError("a coast-down needs the machine file's nominal_supply_pressure_bar")
    viscosity = (
        machine.bearings[0].viscosity_pa_s  # one oil: every bearing's nominal viscosity
        if machine.oil is None
        else machine.oil.dynamic_viscosity_pa_s(oil_temperature_c)
    )
    speeds = np.asarray(speeds_hz, dtype=float)
    plant = structural_machine(machine, structure)  # its loads' magnitudes and directions
    loads = Rotor.from_machine(plant).bearing_static_loads_n
    positions = np.empty((speeds.size, 2 * len(loads)))
    order = np.argsort(speeds)[::-1]  # from speed down: each solve starts from the last one's position
    solved: dict[tuple, np.ndarray] = {}  # bearings of one geometry and load (the equal split) share solves
    for b, load in enumerate(loads):
        bearing = dataclasses.replace(
            structural_bearing(plant.bearings[b], structure), viscosity_pa_s=viscosity
        )
        key = (bearing, round(float(load), 6))
        if key not in solved:
            column, guess = np.empty((speeds.size, 2)), None
            for k in order:
                equilibrium = static_equilibrium(
                    bearing, load, float(speeds[k]), SupplyPressure(pressure), mesh, initial_guess_m=guess
                )
                guess = column[k] = equilibrium.eccentricity_m
            solved[key] = column
        positions[:, 2 * b : 2 * b + 2] = solved[key]
    return positions


def coast_down_record(
    machine: Machine,
    structure: PlantStructure,
    chain: MeasurementChain,
    duration_s: float,
    slow_roll_fraction: float,
    seed: int,
    dt_s: float = 1e-3,
    mesh: Mesh | None = PLANT_MESH,
) -> dict[str, np.ndarray]:
    """The coast-down record (module docstring) from the nominal speed to ``slow_roll_fraction`` of it over
    ``duration_s``: columns ``time_s``, ``speed_hz`` and the probe readings (K, 4) [m] along the probes'
    axes, ``readings_m``, at the nominal oil temperature (``oil_temperature_c``)."""
    require_in_range("coast-down duration", duration_s, 10.0, 3600.0, "s")
    require_in_range("slow-roll fraction", slow_roll_fraction, *SLOW_ROLL_RANGE)
    nominal = machine.nominal_speed_hz
    temperature = machine.nominal_oil_temperature_c
    nodes = nominal * np.geomspace(slow_roll_fraction, 1.0, NODES)
    centreline = CubicSpline(
        np.log(nodes), coast_down_centreline(machine, structure, nodes, temperature, mesh), axis=0
    )
    time = np.arange(round(duration_s / dt_s) + 1) * dt_s
    rate = math.log(slow_roll_fraction) / duration_s  # ln N falls linearly
    speed = nominal * np.exp(rate * time)
    angle = 2.0 * math.pi * nominal * np.expm1(rate * time) / rate
    true = centreline(np.log(speed))
    readings = np.array([chain.probe_readings(x, a) for x, a in zip(true, angle, strict=True)])
    readings += np.random.default_rng([seed, 31]).normal(0.0, chain.noise_std_m, readings.shape)
    return {
        "time_s": time,
        "speed_hz": speed,
        "readings_m": readings,
        "oil_temperature_c": np.full(time.size, temperature),
    }
