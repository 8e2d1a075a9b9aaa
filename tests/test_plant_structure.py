"""The plant's model-structure discrepancies change its response as the physics says (independent checks)."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from oilwatch.models.bearing.equilibrium import coefficients_at, static_equilibrium
from oilwatch.models.bearing.grid import PRODUCTION_MESH, Mesh
from oilwatch.models.bearing.supply import SupplyFlow, SupplyPressure
from oilwatch.models.bearing.table import flooded_threshold
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.coast_down import coast_down_centreline
from oilwatch.models.system.factory import build_system
from oilwatch.models.system.structure import (
    PlantStructure,
    bow_shape,
    structural_machine,
    structural_rotor,
    structural_system,
)
from oilwatch.models.validation import InputError
from oilwatch.robustness.cases import PEDESTALS, RUNOUT_RANGE_M, case_by_name, probe_errors
from oilwatch.robustness.runner import REPORT_SETTINGS, RobustnessRun


@pytest.fixture(scope="module")
def machine():
    return load_machine(None)


@pytest.fixture(scope="module")
def nominal(machine):
    q = machine.shared_nominal_flowrate_m3_s("this test")
    return (q, q)


def _static_um(system, q):
    return system.bearing_positions(system.static_coordinates(q)) * 1e6


def _orbit(system, q):
    return system.bearing_positions(system.unbalance_coordinates(q))


def test_the_default_structure_is_the_machine_files_plant(machine, nominal):
    """On the dimensionless table instead of the 75 Hz flowrate table: static positions within 0.01 um,
    1x orbits within 0.3 %."""
    reference = build_system(machine, reduced=False)
    plant = structural_system(machine, PlantStructure())
    assert np.abs(_static_um(plant, nominal) - _static_um(reference, nominal)).max() < 0.01
    ratio = np.abs(_orbit(plant, nominal)) / np.abs(_orbit(reference, nominal))
    assert np.abs(ratio - 1.0).max() < 3e-3


def test_pedestals_resonate_at_their_own_frequency_and_carry_the_film_force(machine, nominal):
    structure = PlantStructure(**PEDESTALS)
    plant = structural_system(machine, structure)
    n = plant.rotor.n_dof
    # the pedestal coordinates (appended, not coupled to the rotor except through the film):
    # their undamped frequency without the film is sqrt(k / m) / 2 pi
    block_m, block_k = plant.mass[n:, n:], plant.stiffness[n:, n:]
    frequencies = np.sqrt(np.linalg.eigvalsh(np.linalg.solve(block_m, block_k))) / (2 * math.pi)
    expected = math.sqrt(PEDESTALS["pedestal_stiffness_n_m"] / PEDESTALS["pedestal_mass_kg"]) / (2 * math.pi)
    assert np.allclose(frequencies, expected, rtol=1e-12) and 180.0 < expected < 190.0
    assert structure.pedestals.natural_frequency_hz == pytest.approx(expected)
    # the 1x motion of each pedestal obeys its own equation, with the synchronous film's impedance acting
    # on the journal's motion relative to it: (k - m W^2 + i W c) X_p = (K_s + i W C_s) (X_j - X_p)
    x = plant.unbalance_coordinates(nominal)
    w = plant.omega_rad_s
    k, m, c = (
        PEDESTALS[name] for name in ("pedestal_stiffness_n_m", "pedestal_mass_kg", "pedestal_damping_n_s_m")
    )
    for b, table in enumerate(plant.synchronous_tables):
        film = table.evaluate(nominal[b])
        relative = plant.bearing_positions(x)[b]
        pedestal = x[n + 2 * b : n + 2 * b + 2]
        force = (film.stiffness + 1j * w * film.damping) @ relative
        assert np.allclose(
            (k - m * w * w + 1j * w * c) * pedestal, force, rtol=1e-8, atol=1e-9 * np.abs(force).max()
        )
    # the static position relative to the housing does not change (the film still carries W / 2)...
    assert (
        np.abs(
            _static_um(plant, nominal) - _static_um(structural_system(machine, PlantStructure()), nominal)
        ).max()
        < 1e-6
    )
    # ...but the 1x orbit does (the support shares the motion)
    rigid = np.abs(_orbit(structural_system(machine, PlantStructure()), nominal))
    assert np.all(np.abs(np.abs(_orbit(plant, nominal)) / rigid - 1.0) > 0.1)
    with pytest.raises(InputError, match="give both"):
        PlantStructure(pedestal_mass_kg=100.0)


def test_the_unbalance_over_discs_is_the_superposition_of_single_disc_responses(machine, nominal):
    discs = ((10, 0.6, 1.0), (13, 0.4, 0.0), (15, 0.6, -2.6))
    spread = _orbit(structural_system(machine, PlantStructure(unbalance_discs=discs)), nominal)
    singles = [
        _orbit(structural_system(machine, PlantStructure(unbalance_discs=(d,))), nominal) for d in discs
    ]
    assert np.allclose(spread, sum(singles), rtol=1e-10, atol=1e-15)
    # one disc at the machine's node with the whole moment is the machine's plant
    alone = _orbit(structural_system(machine, PlantStructure(unbalance_discs=((13, 1.0, 0.0),))), nominal)
    assert np.allclose(alone, _orbit(structural_system(machine, PlantStructure()), nominal), rtol=1e-12)
    assert np.abs(spread - alone).max() > 0.3 * np.abs(alone).max()


def test_probe_signal_minus_shaft_motion_is_the_runout_at_the_keyphasor_phase():
    run = RobustnessRun({**REPORT_SETTINGS, "duration_s": 2.0})
    case = case_by_name("runout-1-3um")
    probes = probe_errors(case, 1, 2.0, True)
    chain = run.chain(case, True)
    true = np.array([10e-6, -5e-6, 12e-6, -6e-6])
    for angle in (0.0, 1.0, 4.0):
        reading = chain.probe_readings(true, angle) - chain.projection @ true
        offsets = np.array([p.zero_offset_m for p in probes])
        expected = [
            p.runout_1x_m * math.cos(angle + p.runout_1x_phase_rad)
            + p.runout_2x_m * math.cos(2 * angle + p.runout_2x_phase_rad)
            for p in probes
        ]
        assert np.allclose(reading - offsets, expected, atol=1e-15)
    for p in probes:
        assert RUNOUT_RANGE_M[0] <= p.runout_1x_m <= RUNOUT_RANGE_M[1]
        assert RUNOUT_RANGE_M[0] <= p.runout_2x_m <= RUNOUT_RANGE_M[1]
    assert not case.compensate_runout  # no slow-roll record


def test_a_clearance_change_moves_the_journal_as_a_direct_film_solve_at_that_clearance(machine, nominal):
    """The plant's clearance table (the machine's dimensionless table through the Sommerfeld scaling)
    against an independent p-theta equilibrium of the bearing with c = 1.1 c_0 (same production mesh)."""
    factor = 1.1
    plant = structural_system(machine, PlantStructure(clearance_factor=factor))
    e_table = plant.bearing_states(nominal)[0].equilibrium_m
    bearing = machine.bearing
    wider = type(bearing)(**{**bearing.__dict__, "clearance_m": bearing.clearance_m * factor})
    load = float(plant.static_loads_n[0])
    direct = static_equilibrium(wider, load, machine.nominal_speed_hz, SupplyFlow(nominal[0]))
    assert np.abs(e_table - direct.eccentricity_m).max() < 0.01 * np.linalg.norm(direct.eccentricity_m)
    # and the Sommerfeld number falls as 1 / c^2: a larger clearance carries the load at a larger ratio
    base = structural_system(machine, PlantStructure()).bearing_states(nominal)[0].equilibrium_m
    assert (
        np.linalg.norm(e_table) / (factor * bearing.clearance_m) > np.linalg.norm(base) / bearing.clearance_m
    )


@pytest.mark.parametrize("fraction", [0.99, 1.01])
def test_a_one_sided_threshold_plant_has_the_direct_solves_coefficients_beside_q_t(machine, fraction):
    """Just below and above bearing 1's flooded threshold at the nominal point, the plant with
    ``threshold_one_sided`` against an independent p-theta solve (production mesh, quasi-static
    coefficients): within 1 % of the largest stiffness and damping, where the estimator's interpolation across
    the threshold (the default plant's) is off by more than twice as much in stiffness."""
    load = float(structural_system(machine, PlantStructure()).static_loads_n[0])
    q_t, _ = flooded_threshold(machine.bearing, load, machine.nominal_speed_hz, PRODUCTION_MESH)
    q = fraction * q_t
    eq = static_equilibrium(machine.bearing, load, machine.nominal_speed_hz, SupplyFlow(q), PRODUCTION_MESH)
    stiffness, damping = coefficients_at(
        machine.bearing, eq, machine.nominal_speed_hz, SupplyFlow(q), PRODUCTION_MESH
    )

    def errors(structure):
        row = structural_system(machine, structure).tables[0].evaluate(q)
        return (
            np.abs(row.stiffness - stiffness).max() / np.abs(stiffness).max(),
            np.abs(row.damping - damping).max() / np.abs(damping).max(),
        )

    one_sided, across = errors(PlantStructure(threshold_one_sided=True)), errors(PlantStructure())
    assert max(one_sided) < 0.01, one_sided
    assert across[0] > 2.0 * one_sided[0], (across, one_sided)


def test_a_one_sided_threshold_needs_the_machines_bearing_length():
    with pytest.raises(InputError, match="threshold_one_sided needs length_factor 1"):
        PlantStructure(threshold_one_sided=True, length_factor=1.05)


@pytest.mark.parametrize(
    ("angle_deg", "side"),
    [(270.0, (1.0, 0.0)), (90.0, (-1.0, 0.0)), (0.0, (0.0, 1.0))],
    ids=["+x", "-x", "up"],
)
def test_a_side_force_is_the_vector_sum_the_plants_bearings_carry(machine, angle_deg, side):
    """Each bearing's load is its weight share (0, -W_i) plus 0.3 W_i along ``side``, and the plant's rotor
    carries that as an external force at the bearing's node; 30 % horizontal: 1.044 W_i at 196.7 deg."""
    structure = PlantStructure(side_load_fraction=0.3, side_load_angle_deg=angle_deg)
    shares = Rotor.from_machine(machine).bearing_static_loads_n
    rotor = structural_rotor(machine, structure)
    angles = rotor.bearing_load_angles_rad
    loads = rotor.bearing_static_loads_n[:, None] * np.column_stack([-np.sin(angles), np.cos(angles)])
    expected = shares[:, None] * (np.array([0.0, -1.0]) + 0.3 * np.array(side))
    np.testing.assert_allclose(loads, expected, rtol=0, atol=1e-12 * shares.max())
    external = rotor.static_force - rotor.gravity_force
    for node, share in zip(rotor.bearing_nodes, shares, strict=True):
        at = [rotor.dof(node, "x"), rotor.dof(node, "y")]
        np.testing.assert_allclose(external[at], 0.3 * share * np.array(side), rtol=0, atol=1e-9 * share)
        external[at] = 0.0
    assert not external.any()  # nowhere else
    xs, ys = ([rotor.dof(n, a) for n in range(1, rotor.n_nodes + 1)] for a in ("x", "y"))
    np.testing.assert_allclose(  # the load vectors are the rotor's whole static load
        [rotor.static_force[xs].sum(), rotor.static_force[ys].sum()],
        loads.sum(axis=0),
        rtol=0,
        atol=1e-12 * shares.sum(),
    )
    assert structural_machine(machine, structure).bearings[0].load_angle_rad == angles[0]
    if angle_deg == 270.0:
        assert rotor.bearing_static_loads_n / shares == pytest.approx(math.sqrt(1.09), rel=1e-12)
        assert np.degrees(angles) == pytest.approx(180.0 + math.degrees(math.atan(0.3)), rel=1e-12)


def test_the_side_loaded_plants_coast_down_is_the_direct_solve_of_its_turned_load(machine):
    """The coast-down solves each bearing at the plant's load and direction (a 40 x 10 mesh: a wiring check),
    which moves the journal by micrometres from the machine's."""
    mesh, speed = Mesh(40, 10), machine.nominal_speed_hz
    structure = PlantStructure(side_load_fraction=0.3)
    temperature = machine.nominal_oil_temperature_c
    positions = coast_down_centreline(machine, structure, [speed], temperature, mesh=mesh)
    rotor = structural_rotor(machine, structure)
    bearing = dataclasses.replace(
        machine.bearings[0],
        load_angle_rad=float(rotor.bearing_load_angles_rad[0]),
        viscosity_pa_s=machine.oil.dynamic_viscosity_pa_s(temperature),
    )
    pressure = SupplyPressure(machine.lubrication.nominal_supply_pressure_pa)
    direct = static_equilibrium(bearing, rotor.bearing_static_loads_n[0], speed, pressure, mesh)
    np.testing.assert_allclose(positions[0, :2], direct.eccentricity_m, rtol=0, atol=1e-12)
    own = coast_down_centreline(machine, PlantStructure(), [speed], temperature, mesh=mesh)
    assert np.linalg.norm(positions[0, :2] - own[0, :2]) > 1e-6


def test_a_side_force_at_its_default_leaves_the_machines_plant(machine):
    for structure in (PlantStructure(), PlantStructure(side_load_angle_deg=90.0)):  # no force: no direction
        assert structural_machine(machine, structure) is machine
        assert not structure.solved_tables
        rotor, own = structural_rotor(machine, structure), Rotor.from_machine(machine)
        assert np.array_equal(rotor.static_force, own.static_force)
        assert np.array_equal(rotor.bearing_static_loads_n, own.bearing_static_loads_n)
    assert PlantStructure(side_load_fraction=0.3).solved_tables  # the machine's tables are for down


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"side_load_fraction": -0.1}, "side_load_fraction"),
        ({"side_load_fraction": 1.5}, "side_load_fraction"),
        ({"side_load_fraction": math.nan}, "side_load_fraction"),
        ({"side_load_angle_deg": 400.0}, "side_load_angle_deg"),
        ({"side_load_fraction": 0.3, "threshold_one_sided": True}, "threshold_one_sided needs side_load"),
    ],
)
def test_a_side_force_the_plant_cannot_take_is_refused_in_one_line(values, message):
    with pytest.raises(InputError, match=message) as raised:
        PlantStructure(**values)
    assert "\n" not in str(raised.value)


def test_the_statics_split_of_the_turbine_is_its_reactions(machine):
    """The support reactions by hand (shaft elements and annular discs, moments about bearing 1) against
    the rotor's; for the paper's turbine they are equal to 0.003 %."""
    rotor = structural_rotor(machine, PlantStructure(load_split="reactions"))
    lengths, diameters = machine.element_lengths_m, machine.element_diameters_m
    rho, g = machine.material.density_kg_m3, machine.gravity_m_s2
    x = np.concatenate([[0.0], np.cumsum(lengths)])
    weights = [
        (rho * math.pi * d * d / 4 * le * g, x0 + le / 2)
        for d, le, x0 in zip(diameters, lengths, x[:-1], strict=True)
    ]
    for disc in machine.discs:
        area = math.pi * (disc.outer_diameter_m**2 - disc.bore_diameter_m**2) / 4
        weights.append((rho * area * disc.width_m * g, x[disc.node - 1]))
    a, b = (x[node - 1] for node in machine.bearing_nodes)
    second = sum(w * (xw - a) for w, xw in weights) / (b - a)
    total = sum(w for w, _ in weights)
    assert np.allclose(rotor.bearing_static_loads_n, [total - second, second], rtol=1e-9)


def test_a_bowed_shaft_on_rigid_supports_takes_its_bow_and_shows_no_runout_at_the_bearings(machine):
    rotor = structural_rotor(machine, PlantStructure())
    bow = bow_shape(rotor, 10e-6, 0.3)
    fixed = [rotor.dof(n, a) for n in rotor.bearing_nodes for a in ("x", "y")]
    assert np.abs(bow[fixed]).max() == 0.0
    free = np.setdiff1d(np.arange(rotor.n_dof), fixed)
    load = rotor.stiffness_matrix @ bow
    rest = np.linalg.solve(rotor.stiffness_matrix[np.ix_(free, free)], load[free])
    assert np.allclose(rest, bow[free], rtol=1e-8, atol=1e-15)
    xs = [rotor.dof(n, "x") for n in range(machine.bearing_nodes[0], machine.bearing_nodes[1] + 1)]
    assert np.abs(bow[xs]).max() == pytest.approx(10e-6)
    # forward-rotating: y lags x by 90 deg
    assert np.allclose(
        bow[[rotor.dof(n, "y") for n in range(1, rotor.n_nodes + 1)]],
        -1j * bow[[rotor.dof(n, "x") for n in range(1, rotor.n_nodes + 1)]],
    )


@pytest.mark.slow
def test_a_short_pedestal_case_runs_end_to_end_with_the_discrepancy_in_its_record(tmp_path, capsys):
    """``oilwatch robustness --cases pedestals`` on a 10 s baseline and record: both truth points give a row
    (figures or the reason it failed), and the plant's record carries the pedestals' smaller 1x orbit."""
    from oilwatch.cli import main

    out = tmp_path / "rob"
    assert main(["robustness", "--duration-s", "10", "--cases", "pedestals", "--out", str(out)]) == 0
    rows = json.loads((out / "robustness.json").read_text())["rows"]
    assert [(r["q1_pct"], r["q2_pct"]) for r in rows] == [(100.0, 100.0), (80.0, 90.0)]
    for r in rows:
        if "error" in r:
            assert r["error"]  # shown failing, with its reason
            continue
        assert np.all(np.isfinite(r["error_pct"])) and min(r["std_pct"]) > 0.0
        assert 0.0 <= r["consistent_fraction"] <= 1.0
    table = capsys.readouterr().out
    assert "| pedestals | 100/100 |" in table and "Model-structure cases" in table

    run = RobustnessRun({**REPORT_SETTINGS, "duration_s": 2.0})
    ratio = []
    for name in ("pedestals", "structure-reference"):
        true, angle, _ = run.true_motion(case_by_name(name), (100.0, 100.0), 1)
        phasor = np.exp(-1j * angle)
        ratio.append(np.abs(2.0 * np.mean((true - true.mean(axis=0)) * phasor[:, None], axis=0)))
    # the exact 1x solve gives 0.69-0.73 of the rigid supports' amplitude
    assert np.all((0.64 < ratio[0] / ratio[1]) & (ratio[0] / ratio[1] < 0.78))


@pytest.fixture(scope="module")
def geared(tmp_path_factory):
    """The turbine with a 5000 N gear force at its central disc (the bearings' loads the statics')."""
    from fixtures.venvs import REPO_ROOT

    text = (REPO_ROOT / "models" / "turbine.toml").read_text(encoding="utf-8")
    path = tmp_path_factory.mktemp("geared") / "geared.toml"
    path.write_text(text + "\n[[static_forces]]\nnode = 13\nforce_n = 5000.0\nangle_deg = 100.0\n", "utf-8")
    return load_machine(path)


def test_a_side_force_on_a_machine_with_static_forces_adds_to_the_statics_loads(geared):
    """The plant's bearings carry the statics' loads (weight share and gear reaction) plus the side force: the
    side force is not lost where the machine's loads come from static forces."""
    own = Rotor.from_machine(geared)
    shares = Rotor.from_machine(dataclasses.replace(geared, static_forces=())).bearing_static_loads_n
    rotor = structural_rotor(geared, PlantStructure(side_load_fraction=0.3))

    def vectors(r):
        a = r.bearing_load_angles_rad
        return r.bearing_static_loads_n[:, None] * np.column_stack([-np.sin(a), np.cos(a)])

    expected = vectors(own) + 0.3 * shares[:, None] * np.array([1.0, 0.0])
    np.testing.assert_allclose(vectors(rotor), expected, rtol=0, atol=1e-9 * shares.max())
    # the same resultant: the gear force carried at the bearings as its reactions
    np.testing.assert_allclose(
        [rotor.static_force[0::4].sum(), rotor.static_force[1::4].sum()],
        vectors(rotor).sum(axis=0),
        atol=1e-6,
    )


def test_another_load_split_turns_a_geared_machines_loads_and_needs_solved_tables(geared):
    """Under the support reactions instead of equal halves the gear machine's loads turn a little: the plant
    takes its own statics' directions, so the machine's tables (solved at the file's) cannot serve it."""
    structure = PlantStructure(load_split="reactions")
    plant = structural_machine(geared, structure)
    angles = [b.load_angle_rad for b in plant.bearings]
    assert angles != [b.load_angle_rad for b in geared.bearings]
    np.testing.assert_allclose(
        angles, structural_rotor(geared, structure).bearing_load_angles_rad, rtol=1e-12
    )
    with pytest.raises(InputError, match="threshold_one_sided needs the machine's load directions") as raised:
        structural_system(geared, PlantStructure(load_split="reactions", threshold_one_sided=True))
    assert "\n" not in str(raised.value)
    assert structural_machine(geared, PlantStructure()) is geared  # nothing turned: the machine's tables
