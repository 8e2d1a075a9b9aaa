"""The flooded centreline and the clearance measured from it (models/bearing/centreline.py,
models/system/clearance.py), against direct p-theta solves of bearings the locus was not solved for."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from oilwatch.models.bearing.centreline import FloodedLocus, centreline_points, fit_clearance, load_loci
from oilwatch.models.bearing.equilibrium import static_equilibrium
from oilwatch.models.bearing.grid import PRODUCTION_MESH, Mesh
from oilwatch.models.bearing.sommerfeld import sommerfeld_number
from oilwatch.models.bearing.supply import SupplyPressure
from oilwatch.models.machine import load_machine
from oilwatch.models.probes import read_probes
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.clearance import measure_clearances, record_revolutions
from oilwatch.models.system.coast_down import coast_down_centreline, coast_down_record
from oilwatch.models.system.factory import build_system, locus_table_path
from oilwatch.models.system.measurement import MeasurementChain, ProbeErrors
from oilwatch.models.system.operating_model import build_operating_model
from oilwatch.models.system.structure import PlantStructure, structural_system
from oilwatch.models.validation import InputError

MACHINE = load_machine(None)
BEARING = MACHINE.bearing
LOAD = float(Rotor.from_machine(MACHINE).bearing_static_loads_n[0])
PRESSURE = MACHINE.lubrication.nominal_supply_pressure_pa
LOCUS_MESH = Mesh(96, 24)
"""Coarse: the tests compare the locus with solves on other meshes, so each is its own reference."""
PLANT_MESH = Mesh(120, 30)
SPEEDS = MACHINE.nominal_speed_hz * np.geomspace(0.03, 1.0, 16)
OFFSETS_M = np.array([14e-6, -21e-6])


@pytest.fixture(scope="module")
def locus():
    return FloodedLocus.compute(BEARING, LOAD, PRESSURE, LOCUS_MESH)


def _direct(bearing, speeds, mesh):
    positions, guess = [], None
    for speed in speeds[::-1]:
        guess = static_equilibrium(
            bearing, LOAD, speed, SupplyPressure(PRESSURE), mesh, initial_guess_m=guess
        ).eccentricity_m
        positions.append(guess)
    return np.array(positions[::-1])


def test_the_locus_between_its_nodes_is_a_direct_solve_on_its_mesh(locus):
    """Half-way between nodes in ln S, the cubic against the equilibrium solved there (same mesh)."""
    s = np.sqrt(locus.sommerfeld_nodes[8:24:4] * locus.sommerfeld_nodes[9:25:4])
    per_hz = sommerfeld_number(BEARING, BEARING.viscosity_pa_s, 1.0, LOAD)
    direct = _direct(BEARING, s / per_hz, LOCUS_MESH) / BEARING.clearance_m
    assert np.abs(locus.position(s) - direct).max() < 2e-4


def test_a_bearing_of_another_clearance_and_viscosity_lies_on_the_locus_scaled_by_its_clearance(locus):
    """The pressure-fed locus's scaling (the module docstring: p_s c^2 / (mu Omega R^2) times S is a
    constant): a bearing 12 % tighter with a 30 % thicker oil, solved directly, is g c E(S)."""
    other = dataclasses.replace(
        BEARING, clearance_m=0.88 * BEARING.clearance_m, viscosity_pa_s=1.3 * BEARING.viscosity_pa_s
    )
    speeds = np.array([3.0, 12.0, 40.0])
    direct = _direct(other, speeds, LOCUS_MESH)
    s = np.array([sommerfeld_number(other, other.viscosity_pa_s, n, LOAD) for n in speeds])
    scaled = other.clearance_m * locus.position(s)
    assert np.abs(scaled - direct).max() < 2e-4 * BEARING.clearance_m


@pytest.mark.parametrize(
    ("clearance_factor", "viscosity_factor"),
    [
        (0.9, 1.1),
        pytest.param(1.1, 0.9, marks=pytest.mark.slow),
        pytest.param(1.0, 1.25, marks=pytest.mark.slow),
    ],
    ids=str,
)
def test_the_fit_measures_the_clearance_of_a_bearing_solved_on_another_mesh(
    locus, clearance_factor, viscosity_factor
):
    """Offsets unknown, film viscosity unknown: the clearance within 0.5 % and within 4 of its std."""
    plant = dataclasses.replace(
        BEARING,
        clearance_m=clearance_factor * BEARING.clearance_m,
        viscosity_pa_s=viscosity_factor * BEARING.viscosity_pa_s,
    )
    noise = 0.03e-6
    measured = _direct(plant, SPEEDS, PLANT_MESH) + OFFSETS_M
    measured += np.random.default_rng(3).normal(0.0, noise, measured.shape)
    fit = fit_clearance(locus, BEARING, LOAD, SPEEDS, BEARING.viscosity_pa_s, measured, noise)
    assert abs(fit.clearance_factor / clearance_factor - 1.0) < 0.005
    assert abs(fit.clearance_factor - clearance_factor) < 4.0 * fit.clearance_factor_std
    assert abs(fit.viscosity_factor / viscosity_factor - 1.0) < 0.02
    np.testing.assert_allclose(fit.offsets_m, OFFSETS_M, atol=0.005 * BEARING.clearance_m)


@pytest.mark.slow
def test_a_bearing_of_another_length_is_read_as_a_nearby_clearance_and_film(locus):
    """L/D is not a scaling of the locus, but a bearing 5 % longer is nearly one of another clearance and
    viscosity: the clearance within 1 %, the residual above that of a bearing of the machine's length."""
    noise = 0.03e-6
    residuals = []
    for length_factor in (1.0, 1.05):
        plant = dataclasses.replace(
            BEARING, clearance_m=1.1 * BEARING.clearance_m, length_m=length_factor * BEARING.length_m
        )
        measured = _direct(plant, SPEEDS, PLANT_MESH) + OFFSETS_M
        fit = fit_clearance(locus, BEARING, LOAD, SPEEDS, BEARING.viscosity_pa_s, measured, noise)
        assert abs(fit.clearance_factor / 1.1 - 1.0) < 0.01
        residuals.append(fit.residual_rms_m)
    assert residuals[1] > residuals[0]


@pytest.mark.parametrize(
    ("speeds", "message"),
    [
        (SPEEDS[:5], "at least 6 speeds"),
        (np.linspace(40.0, 75.0, 8), "speed ratio of at least 3"),
        (np.r_[SPEEDS[:-1], np.nan], "positive"),
    ],
    ids=["few", "narrow", "nan"],
)
def test_a_centreline_the_fit_cannot_use_is_refused_in_one_line(locus, speeds, message):
    positions = np.zeros((len(speeds), 2))
    with pytest.raises(InputError, match=message) as raised:
        fit_clearance(locus, BEARING, LOAD, speeds, BEARING.viscosity_pa_s, positions, 1e-8)
    assert "\n" not in str(raised.value)


def test_samples_are_averaged_per_speed_bin():
    speed = np.repeat([10.0, 20.0, 40.0], 100) * (1.0 + 1e-4 * np.tile(np.arange(100), 3))
    values = np.column_stack([speed, 2.0 * speed])
    speeds, means, counts = centreline_points(speed, values, 1.05, 50)
    np.testing.assert_allclose(means[:, 0], speeds)
    np.testing.assert_allclose(means[:, 1], 2.0 * speeds)
    assert counts.tolist() == [100, 100, 100]


@pytest.mark.slow
def test_a_plant_coast_down_at_another_clearance_is_the_direct_solve_of_that_bearing():
    structure = PlantStructure(clearance_factor=0.9, length_factor=1.05)
    speeds = np.array([5.0, 50.0])
    positions = coast_down_centreline(
        MACHINE, structure, speeds, MACHINE.nominal_oil_temperature_c, mesh=PLANT_MESH
    )
    bearing = dataclasses.replace(
        BEARING, clearance_m=0.9 * BEARING.clearance_m, length_m=1.05 * BEARING.length_m
    )
    np.testing.assert_allclose(positions[:, :2], _direct(bearing, speeds, PLANT_MESH), rtol=0, atol=1e-12)


def test_the_estimators_model_at_a_measured_clearance_is_the_plant_of_that_clearance():
    """The operating model on tables of another clearance (``OperatingTable.with_clearance``) against the
    plant's clearance table (the structure's, built another way): the static journal positions."""
    factor = 0.9
    reduced = build_system(MACHINE, reduced=True)
    model = build_operating_model(reduced, MACHINE, clearance_factors=(factor, factor))
    plant = structural_system(MACHINE, PlantStructure(clearance_factor=factor))
    q = np.array(MACHINE.lubrication.nominal_flowrates_m3_s)
    plant_static = plant.bearing_positions(plant.static_coordinates(q)).ravel()
    model_static = np.array([s.equilibrium_m for s in model.reference.system.bearing_states(q)]).ravel()
    # the plant's full rotor loads its bearings 1e-5 unequally; the reduced model's split is the file's
    np.testing.assert_allclose(model_static, plant_static, rtol=0, atol=1e-4 * BEARING.clearance_m)
    unchanged = build_operating_model(reduced, MACHINE)
    moved = np.array([s.equilibrium_m for s in unchanged.reference.system.bearing_states(q)]).ravel()
    assert np.abs(moved - plant_static).max() > 0.01 * BEARING.clearance_m


def test_a_clearance_factor_outside_the_measurable_range_is_refused():
    reduced = build_system(MACHINE, reduced=True)
    with pytest.raises(InputError, match="clearance factor"):
        build_operating_model(reduced, MACHINE, clearance_factors=(1.0, 2.0))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["turbine", "compressor"])
def test_a_node_of_a_bundled_locus_file_is_what_its_command_solves(name):
    """A middle node of ``models/tables/<machine>_bearing_locus.json`` (``oilwatch bearing-locus``)
    solved again on the production mesh from its neighbour's position, as the command does."""
    machine = load_machine(name)
    (locus,) = load_loci(locus_table_path(machine))
    meta = locus.metadata
    bearing = dataclasses.replace(machine.bearing)
    assert locus.matches(bearing, meta["load_n"], machine.lubrication.nominal_supply_pressure_pa)
    k = locus.sommerfeld_nodes.size // 2
    per_hz = sommerfeld_number(bearing, bearing.viscosity_pa_s, 1.0, meta["load_n"])
    solved = static_equilibrium(
        bearing,
        meta["load_n"],
        locus.sommerfeld_nodes[k] / per_hz,
        SupplyPressure(meta["supply_pressure_pa"]),
        PRODUCTION_MESH,
        initial_guess_m=locus.positions[k + 1] * bearing.clearance_m,
    )
    np.testing.assert_allclose(solved.eccentricity_m / bearing.clearance_m, locus.positions[k], atol=1e-6)


@pytest.mark.slow
def test_a_coast_down_with_a_probe_dropping_out_measures_the_clearance_from_the_rest():
    """A 20 s coast-down of a plant 5 % tighter, its x1 probe missing (NaN) over a quarter of it and 2 um of
    1x runout on every probe: whole revolutions without the gap, the clearance within 0.5 %."""
    chain = MeasurementChain(
        tuple(ProbeErrors(zero_offset_m=o, runout_1x_m=2e-6) for o in (10e-6, -20e-6, 5e-6, 15e-6)), 0.0, 1e-6
    )
    record = coast_down_record(MACHINE, PlantStructure(clearance_factor=0.95), chain, 20.0, 0.03, seed=4)
    readings = record["readings_m"].copy()
    readings[5000:10000, 0] = np.nan
    fits = measure_clearances(
        MACHINE,
        record["speed_hz"],
        readings,
        1e-6,
        revolutions=record_revolutions(record["speed_hz"], 1e-3),
    )
    assert all(abs(fit.clearance_factor / 0.95 - 1.0) < 0.005 for fit in fits)


@pytest.mark.slow
def test_the_clearance_std_covers_the_spread_of_the_probes_scale_factor_errors():
    """Each probe of the machine file's pair (45 deg from the model's axes) reads 1 + delta times its
    signal, delta uniform within the machine file's tolerance (API 670's 5 %): the rms change of each
    measured clearance over 12 draws against the std's scale-factor term (the std with the tolerance and
    without it, in quadrature). 12 draws: the rms is known to about 20 %."""
    probes = read_probes(MACHINE)
    chain = MeasurementChain((ProbeErrors(),) * 4, math.radians(probes.angle_deg), 1e-6)
    record = coast_down_record(MACHINE, PlantStructure(), chain, 20.0, 0.03, seed=6)
    revolutions = record_revolutions(record["speed_hz"], 1e-3)

    def measured(delta, scale_std=0.0):
        positions = (record["readings_m"] * (1.0 + delta)) @ chain.projection  # back to the model's axes
        fits = measure_clearances(
            MACHINE,
            record["speed_hz"],
            positions,
            1e-6,
            revolutions=revolutions,
            probe_scale_factor_std=scale_std,
        )
        return np.array([[fit.clearance_factor, fit.clearance_factor_std] for fit in fits])

    exact = measured(np.zeros(4))
    term = np.sqrt(measured(np.zeros(4), probes.scale_factor_std)[:, 1] ** 2 - exact[:, 1] ** 2)
    tolerance = probes.scale_factor_std * math.sqrt(3.0)
    rng = np.random.default_rng(11)
    shifts = [measured(rng.uniform(-tolerance, tolerance, 4))[:, 0] - exact[:, 0] for _ in range(12)]
    spread = np.sqrt(np.mean(np.square(shifts), axis=0))
    assert np.all((0.6 * spread < term) & (term < 1.6 * spread)), (spread, term)


@pytest.mark.parametrize(
    ("structure", "probe_error", "explained"),
    [
        (PlantStructure(), 0.05, True),  # API 670's scale-factor tolerance on every probe, alternating
        (PlantStructure(side_load_fraction=0.3, side_load_angle_deg=270.0), 0.0, False),
    ],
    ids=["probes 5 % off", "an unknown side force"],
)
def test_a_centreline_that_is_not_the_files_bearing_keeps_the_files_clearance(
    structure, probe_error, explained
):
    """A side force the machine file does not give turns the locus; the fit makes up for it with a 10 % wider
    clearance and a film 2.25 x as viscous as the oil supplied, which the estimator's model must not take."""
    from oilwatch.estimator.baseline import clearance_document
    from oilwatch.robustness.coast_down import measured_clearances

    errors = (probe_error, -probe_error) * 2
    chain = MeasurementChain(probes=tuple(ProbeErrors(sensitivity_error=e) for e in errors), noise_std_m=1e-6)
    fits = measured_clearances(MACHINE, structure, chain, 1, 0.0)
    document = clearance_document(fits)
    for b, fit in enumerate(fits):
        assert fit.explains_centreline is explained
        if explained:
            assert fit.viscosity_factor < 1.3 and fit.applied_clearance_factor == fit.clearance_factor
        else:
            assert fit.viscosity_factor > 2.0 and abs(fit.clearance_factor - 1.0) > 0.05
            assert fit.applied_clearance_factor == 1.0
        assert document["clearance_factor"][b] == fit.applied_clearance_factor
        assert document["coast_down"]["measured_clearance_factor"][b] == fit.clearance_factor
        assert document["coast_down"]["explains_centreline"][b] is explained
