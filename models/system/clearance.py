"""Each bearing's radial clearance measured from a coast-down or run-up record of the machine.

The machine-level side of :mod:`oilwatch.models.bearing.centreline`: the record's samples are averaged into
centreline points (speed bins), each bearing's points are fitted with the flooded locus of its geometry in
the machine file at that bearing's static load and the nominal supply pressure, and the film viscosity at
each point is the oil law's at the record's oil temperature (the machine's nominal supply temperature when
it has none).
The clearance factors feed the estimator's operating model
(:func:`oilwatch.models.system.operating_model.build_operating_model`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..bearing.centreline import (
    ClearanceFit,
    FloodedLocus,
    centreline_points,
    fit_clearance,
    flooded_locus,
    load_loci,
    revolution_means,
)
from ..machine import Machine
from ..probes import read_probes
from ..rotor.assembly import Rotor
from ..validation import InputError
from .factory import locus_table_path
from .measurement import probe_axes

CENTRELINE_BIN_RATIO = 1.03
"""Speed bins of 3 % (uniform in ln N) for the record's centreline points."""
SCALE_STEP = 0.01
"""The stretch of one axis's readings by which the clearance's sensitivity to a probe scale factor is
found by refitting."""
MIN_BIN_SAMPLES = 50
"""Samples a speed bin needs to be a centreline point (50 ms at 1 kHz: many revolutions above 20 Hz)."""


def measure_clearances(
    machine: Machine,
    speed_hz,
    positions_m,
    noise_std_m: float,
    oil_temperature_c=None,
    revolutions=None,
    probe_scale_factor_std: float = 0.0,
) -> tuple[ClearanceFit, ...]:
    """Each bearing's :class:`ClearanceFit` from a coast-down or run-up record.

    ``speed_hz`` (K,) the record's speed, ``positions_m`` (K, 4) the journal positions (x1, y1, x2, y2) [m]
    (the probe signals turned into the model's axes), ``noise_std_m`` one sample's noise std,
    ``oil_temperature_c`` (K,) or None, ``revolutions`` (K,) the rotor's turns since the record began (each
    whole revolution is averaged first, which takes the probes' runout out: :func:`revolution_means`), or
    None. The samples are then averaged in speed bins of :data:`CENTRELINE_BIN_RATIO`; a record of a
    centreline (one row per speed, already averaged) is taken as it is, each row with the noise of one
    sample; a sample with a missing value (NaN: a faulty probe's) is left out. ``probe_scale_factor_std``:
    the std of each probe's scale-factor error (``[probes] scale_factor_tolerance_pct``): a probe that reads
    1 + delta times the motion stretches the centreline along its axis, which reads as clearance; the
    clearance factor's std includes it (the fit's sensitivity to each probe's stretch along its own axis,
    found by refitting, times this std).
    """
    speed = np.asarray(speed_hz, dtype=float)
    positions = np.asarray(positions_m, dtype=float)
    if speed.ndim != 1 or positions.shape != (speed.size, 4):
        raise InputError("a coast-down record needs a speed and four probe signals per sample")
    if oil_temperature_c is None:
        temperature = np.full(speed.size, machine.nominal_oil_temperature_c)
    else:
        temperature = np.asarray(oil_temperature_c, dtype=float)
    values = np.column_stack([positions, temperature])
    # samples a probe fault or a gap left out (NaN) are dropped, not averaged in
    whole = np.isfinite(values).all(axis=1) & np.isfinite(speed)
    if whole.sum() < MIN_BIN_SAMPLES:
        raise InputError(
            f"a coast-down record needs at least {MIN_BIN_SAMPLES} samples with every probe and the speed, "
            f"got {int(whole.sum())}"
        )
    speed, values = speed[whole], values[whole]
    one_per_speed = np.unique(speed).size == speed.size
    weights = None
    if revolutions is not None:
        turns = np.asarray(revolutions, dtype=float)[whole]
        speed, values, weights = revolution_means(turns, speed, values)
    speeds, means, counts = centreline_points(
        speed, values, CENTRELINE_BIN_RATIO, 1 if one_per_speed else MIN_BIN_SAMPLES, weights
    )
    if machine.oil is None:
        viscosity = np.full(speeds.size, machine.bearings[0].viscosity_pa_s)  # one oil for every bearing
    else:
        viscosity = np.array([machine.oil.dynamic_viscosity_pa_s(t) for t in means[:, 4]])
    noise = noise_std_m / math.sqrt(float(np.median(counts)))
    loads = Rotor.from_machine(machine).bearing_static_loads_n
    loci = machine_loci(machine)
    axes = probe_axes(math.radians(read_probes(machine).angle_deg))
    fits = []
    for b, (load, locus) in enumerate(zip(loads, loci, strict=True)):
        points = means[:, 2 * b : 2 * b + 2]
        bearing = machine.bearings[b]
        fit = fit_clearance(locus, bearing, load, speeds, viscosity, points, noise)
        if probe_scale_factor_std > 0.0:
            slopes = []
            for axis in axes:
                # the probe reads 1 + delta times its signal: the points stretch along its axis
                stretched = points + SCALE_STEP * np.outer(points @ axis, axis)
                moved = fit_clearance(locus, bearing, load, speeds, viscosity, stretched, noise)
                slopes.append((moved.clearance_factor - fit.clearance_factor) / SCALE_STEP)
            considered = probe_scale_factor_std * math.hypot(*slopes)
            fit = dataclasses.replace(
                fit, clearance_factor_std=math.hypot(fit.clearance_factor_std, considered)
            )
        fits.append(fit)
    return tuple(fits)


def machine_loci(machine: Machine) -> list[FloodedLocus]:
    """Each bearing's flooded locus at its static load and the nominal supply pressure: from the machine's
    locus file (``oilwatch bearing-locus``, :func:`oilwatch.models.system.factory.locus_table_path`) when it
    holds it, else solved on the production mesh and kept in the cache
    (:func:`oilwatch.models.bearing.centreline.flooded_locus`)."""
    pressure = machine.lubrication.nominal_supply_pressure_pa
    if not math.isfinite(pressure):
        raise InputError(
            "measuring the clearance needs the machine file's [lubrication] nominal_supply_pressure_bar "
            "(the flooded locus is that of the groove's pressure)"
        )
    loads = Rotor.from_machine(machine).bearing_static_loads_n
    stored: dict = {}  # the locus file of each bearing geometry (one file when the bearings are alike)
    loci = []
    for index, (bearing, load) in enumerate(zip(machine.bearings, loads, strict=True)):
        path = locus_table_path(machine, index)
        if path not in stored:
            stored[path] = load_loci(path) if path.exists() else []
        found = [locus for locus in stored[path] if locus.matches(bearing, load, pressure)]
        loci.append(found[0] if found else flooded_locus(bearing, load, pressure))
    return loci


def record_revolutions(speed_hz, dt_s: float) -> np.ndarray:
    """(K,) the rotor's turns since the first sample of a record sampled every ``dt_s`` [s] at the speeds
    ``speed_hz`` (K,) [Hz]: the trapezoidal integral of the speed (what a keyphasor counts)."""
    speed = np.asarray(speed_hz, dtype=float)
    turns = np.zeros(speed.size)
    turns[1:] = np.cumsum(0.5 * (speed[1:] + speed[:-1])) * dt_s
    return turns
