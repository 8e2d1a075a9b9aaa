"""A bearing's static load given in the machine file: its direction (``load_angle_deg``) and magnitude
(``[[bearings.override]] static_load_n``), carried through the rotor's statics, the tables and the plant.

The machine is the bundled turbine with its weight shared by the support reactions and its bearing 2
pulled sideways by a given 4500 N at 150 deg (a belt or gear load). The checks:

* statics: the rotor's constant load is its weight plus, at bearing 2 only, the external force that turns
  its weight share into the given load; the resultant is the sum of the bearings' given load vectors;
* consistency: with each bearing's flowrate table computed for its own load (coarse mesh, two flowrates),
  the whole system's static solution and the plant's simulated position put each journal exactly at its
  table's equilibrium (a wrong sign or direction of the external force or of the film's f0 would move
  bearing 2's journal by tens of um);
* the film: bearing 2's equilibrium is the one solved for a load along 150 deg (an attitude measured from
  that load), not the downward one;
* naming and refusals: a bearing loaded along another direction has tables of its own; a table computed
  for the downward load is refused for it in one line; bad values are one-line errors.
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from fixtures.venvs import REPO_ROOT

from oilwatch.models.bearing.equilibrium import static_equilibrium
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.operating_table import geometry_mismatch
from oilwatch.models.bearing.supply import SupplyFlow
from oilwatch.models.bearing.table import compute_table
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.factory import flowrate_table_name
from oilwatch.models.system.plant import RotorBearingPlant
from oilwatch.models.system.rotor_bearing import RotorBearingSystem
from oilwatch.models.validation import InputError

SIDE_LOAD_N = 4500.0
SIDE_ANGLE_DEG = 150.0
MESH = Mesh(60, 10)


def machine_text(override: str, load_split: str = "reactions") -> str:
    text = (REPO_ROOT / "models" / "turbine.toml").read_text(encoding="utf-8")
    text = re.sub(r"(?m)^load_split = .*$", f'load_split = "{load_split}"', text)
    return text.replace("\n[oil]\n", "\n" + override + "\n[oil]\n", 1)


def side_loaded(tmp_path, **keys):
    node = load_machine().bearing_nodes[1]
    values = {"load_angle_deg": SIDE_ANGLE_DEG, "static_load_n": SIDE_LOAD_N, **keys}
    entries = "".join(f"{k} = {v}\n" for k, v in values.items())
    path = tmp_path / "side.toml"
    path.write_text(machine_text(f"[[bearings.override]]\nnode = {node}\n{entries}"), encoding="utf-8")
    return load_machine(path)


@pytest.fixture(scope="module")
def machine(tmp_path_factory):
    return side_loaded(tmp_path_factory.mktemp("side"))


def test_the_file_gives_bearing_2_its_load_and_direction(machine):
    assert machine.bearings[0].load_angle_rad == math.pi  # exactly: the default, bit for bit
    assert machine.bearings[1].load_angle_rad == pytest.approx(math.radians(SIDE_ANGLE_DEG), rel=1e-15)
    assert machine.static_loads_given_n == (None, SIDE_LOAD_N)
    assert machine.bearings_differ  # the same geometry, another load direction: tables of its own
    names = {flowrate_table_name(machine, 75.0, bearing_index=i) for i in (0, 1)}
    assert names == {"side_bearing1_75hz_synchronous.json", "side_bearing2_75hz_synchronous.json"}


def test_the_rotor_carries_the_external_force_that_makes_the_given_load(machine):
    rotor = Rotor.from_machine(machine)
    plain = Rotor.from_machine(
        dataclasses.replace(machine, static_loads_given_n=(), bearings=(machine.bearings[0],) * 2)
    )
    share = plain.bearing_static_loads_n[1]
    np.testing.assert_array_equal(plain.static_force, plain.gravity_force)  # no given load: the weight only
    assert rotor.bearing_static_loads_n[0] == plain.bearing_static_loads_n[0]
    assert rotor.bearing_static_loads_n[1] == SIDE_LOAD_N
    beta = math.radians(SIDE_ANGLE_DEG)
    load = SIDE_LOAD_N * np.array([-math.sin(beta), math.cos(beta)])  # along bearing angle 150 deg
    extra = rotor.static_force - rotor.gravity_force
    x2, y2 = rotor.dof(rotor.bearing_nodes[1], "x"), rotor.dof(rotor.bearing_nodes[1], "y")
    np.testing.assert_allclose(extra[[x2, y2]], load - np.array([0.0, -share]), rtol=1e-13)
    assert not np.delete(extra, [x2, y2]).any()
    # resultant: the weight's shares turn into the given loads
    resultant = np.array([rotor.static_force[0::4].sum(), rotor.static_force[1::4].sum()])
    first = np.array([0.0, -rotor.bearing_static_loads_n[0]])
    np.testing.assert_allclose(resultant, first + load, rtol=1e-9, atol=1e-9 * rotor.weight_n)


@pytest.fixture(scope="module")
def tables(machine):
    rotor = Rotor.from_machine(machine)
    q = machine.lubrication.nominal_flowrates_m3_s
    return [
        compute_table(bearing, load, machine.nominal_speed_hz, [0.8 * q[i], q[i]], MESH)
        for i, (bearing, load) in enumerate(zip(machine.bearings, rotor.bearing_static_loads_n, strict=True))
    ]


def test_each_table_holds_its_bearings_equilibrium_under_its_own_load(machine, tables):
    q = machine.lubrication.nominal_flowrates_m3_s[1]
    row = tables[1].evaluate(q)
    direct = static_equilibrium(
        machine.bearings[1], SIDE_LOAD_N, machine.nominal_speed_hz, SupplyFlow(q), MESH
    )
    np.testing.assert_allclose(row.eccentricity_m, direct.eccentricity_m, rtol=1e-9)
    downward = static_equilibrium(
        dataclasses.replace(machine.bearings[1], load_angle_rad=math.pi),
        SIDE_LOAD_N, machine.nominal_speed_hz, SupplyFlow(q), MESH,
    )  # fmt: skip
    # the same attitude from its own load (the one-groove bearing's groove is at the top, the load at
    # 150 deg is 30 deg away from straight down, so not quite), a position turned towards the load
    assert abs(direct.attitude_deg - downward.attitude_deg) < 15.0
    assert np.linalg.norm(direct.eccentricity_m - downward.eccentricity_m) > 0.2 * np.linalg.norm(
        downward.eccentricity_m
    )
    assert tables[1].metadata["bearing"]["load_angle_rad"] == machine.bearings[1].load_angle_rad


def test_the_system_and_the_plant_hold_each_journal_at_its_tables_equilibrium(machine, tables):
    rotor = Rotor.from_machine(machine)
    system = RotorBearingSystem(rotor, tables, machine.nominal_speed_hz, unbalance_moment_kg_m=0.0)
    q = tuple(machine.lubrication.nominal_flowrates_m3_s)
    e0 = np.array([t.evaluate(qi).eccentricity_m for t, qi in zip(tables, q, strict=True)])
    static = np.einsum("bij,j->bi", system.bearing_maps, system.static_coordinates(q))
    clearance = machine.bearings[0].clearance_m
    np.testing.assert_allclose(static, e0, rtol=0, atol=1e-9 * clearance)
    plant = RotorBearingPlant(system, 1e-3, None, 0.0, seed=1, initial_flowrates_m3_s=q)
    for _ in range(20):
        sample = plant.step(q)
    np.testing.assert_allclose(sample.true_position_m.reshape(2, 2), e0, rtol=0, atol=1e-9 * clearance)


def test_a_table_for_the_downward_load_is_refused_for_the_side_loaded_bearing(machine):
    downward = dataclasses.asdict(dataclasses.replace(machine.bearings[1], load_angle_rad=math.pi))
    assert geometry_mismatch(downward, machine.bearings[1]) == (
        "a load along 180 deg, the bearing's points along 150 deg"
    )
    stored = dataclasses.asdict(machine.bearings[1])
    assert geometry_mismatch(stored, machine.bearings[1]) is None
    stored.pop("load_angle_rad")  # a geometry without a direction (the bundled tables'): downward
    assert geometry_mismatch(stored, machine.bearings[0]) is None


def test_a_direction_alone_keeps_the_weight_share_as_the_magnitude(tmp_path):
    node = load_machine().bearing_nodes[0]
    path = tmp_path / "turned.toml"
    path.write_text(
        machine_text(f"[[bearings.override]]\nnode = {node}\nload_angle_deg = 200.0\n", "equal"),
        encoding="utf-8",
    )
    turned = load_machine(path)
    rotor, plain = Rotor.from_machine(turned), Rotor.from_machine(load_machine())
    np.testing.assert_array_equal(rotor.bearing_static_loads_n, plain.bearing_static_loads_n)
    extra = (rotor.static_force - rotor.gravity_force)[[rotor.dof(node, "x"), rotor.dof(node, "y")]]
    w, beta = plain.bearing_static_loads_n[0], math.radians(200.0)
    np.testing.assert_allclose(extra, w * np.array([-math.sin(beta), math.cos(beta) + 1.0]), rtol=1e-12)


@pytest.mark.parametrize(
    ("keys", "message"),
    [
        ({"static_load_n": 0}, "bearings.override[0].static_load_n must be > 0 N, got 0"),
        ({"static_load_n": -5.0}, "bearings.override[0].static_load_n must be > 0 N"),
        ({"load_angle_deg": '"down"'}, "bearings.override[0].load_angle_deg must be a number"),
        ({"load_angle_deg": "nan"}, "bearings.override[0].load_angle_deg must be"),
    ],
)
def test_bad_load_values_are_refused_in_one_line(tmp_path, keys, message):
    with pytest.raises(InputError, match=re.escape(message)) as error:
        side_loaded(tmp_path, **keys)
    assert "\n" not in str(error.value)


GEAR_NODE, GEAR_FORCE_N, GEAR_ANGLE_DEG = 13, 5000.0, 100.0
"""A gear mesh force at the central disc, nearly horizontal (towards -x, 10 deg below)."""


def with_forces(folder, forces, load_split="reactions", override=""):
    entries = "".join(
        f"[[static_forces]]\nnode = {node}\nforce_n = {force}\nangle_deg = {angle}\n\n"
        for node, force, angle in forces
    )
    path = folder / "gear.toml"
    path.write_text(machine_text(override + "\n" + entries, load_split), encoding="utf-8")
    return load_machine(path)


def test_static_forces_load_the_bearings_by_the_lever_rule(tmp_path):
    """On two bearings the rotor is statically determinate: each bearing's share of a force is the lever
    rule's, whatever the shaft's stiffness; its load is its weight share plus that."""
    machine = with_forces(tmp_path, [(GEAR_NODE, GEAR_FORCE_N, GEAR_ANGLE_DEG)])
    rotor = Rotor.from_machine(machine)
    plain = Rotor.from_machine(
        dataclasses.replace(machine, static_forces=(), bearings=(machine.bearings[0],) * 2)
    )
    z = rotor.node_positions_m
    z1, z2, zf = (z[n - 1] for n in (*rotor.bearing_nodes, GEAR_NODE))
    beta = math.radians(GEAR_ANGLE_DEG)
    force = GEAR_FORCE_N * np.array([-math.sin(beta), math.cos(beta)])
    for b, lever in enumerate(((z2 - zf) / (z2 - z1), (zf - z1) / (z2 - z1))):
        load = np.array([0.0, -plain.bearing_static_loads_n[b]]) + lever * force
        assert rotor.bearing_static_loads_n[b] == pytest.approx(np.hypot(*load), rel=1e-9)
        along = rotor.bearing_static_loads_n[b] * np.array(
            [-math.sin(rotor.bearing_load_angles_rad[b]), math.cos(rotor.bearing_load_angles_rad[b])]
        )
        np.testing.assert_allclose(along, load, rtol=1e-9)
        # the machine's bearings hold the statics' direction, for their tables
        assert machine.bearings[b].load_angle_rad == rotor.bearing_load_angles_rad[b]
    extra = rotor.static_force - rotor.gravity_force  # the force where it acts, nothing at the bearings
    np.testing.assert_allclose(
        extra[[rotor.dof(GEAR_NODE, "x"), rotor.dof(GEAR_NODE, "y")]], force, rtol=1e-13
    )
    assert np.count_nonzero(extra) == 2


def test_a_static_force_at_a_bearing_is_that_bearings_given_load(tmp_path):
    node = load_machine().bearing_nodes[1]
    beta = math.radians(SIDE_ANGLE_DEG)
    share = Rotor.from_machine(with_forces(tmp_path, [])).bearing_static_loads_n[1]  # reactions split
    side = SIDE_LOAD_N * np.array([-math.sin(beta), math.cos(beta)]) - np.array([0.0, -share])
    force_n, angle = float(np.hypot(*side)), math.degrees(math.atan2(-side[0], side[1]))
    forced = Rotor.from_machine(with_forces(tmp_path, [(node, force_n, angle)]))
    given = Rotor.from_machine(side_loaded(tmp_path))
    np.testing.assert_allclose(forced.bearing_static_loads_n, given.bearing_static_loads_n, rtol=1e-9)
    np.testing.assert_allclose(forced.bearing_load_angles_rad, given.bearing_load_angles_rad, rtol=1e-9)
    np.testing.assert_allclose(forced.static_force, given.static_force, rtol=0, atol=1e-9 * SIDE_LOAD_N)


def test_with_static_forces_the_system_holds_each_journal_at_its_tables_equilibrium(tmp_path):
    machine = with_forces(tmp_path, [(GEAR_NODE, GEAR_FORCE_N, GEAR_ANGLE_DEG)])
    rotor = Rotor.from_machine(machine)
    q = tuple(machine.lubrication.nominal_flowrates_m3_s)
    tables = [
        compute_table(bearing, load, machine.nominal_speed_hz, [0.8 * qi, qi], MESH)
        for bearing, load, qi in zip(machine.bearings, rotor.bearing_static_loads_n, q, strict=True)
    ]
    system = RotorBearingSystem(rotor, tables, machine.nominal_speed_hz, unbalance_moment_kg_m=0.0)
    e0 = np.array([t.evaluate(qi).eccentricity_m for t, qi in zip(tables, q, strict=True)])
    static = np.einsum("bij,j->bi", system.bearing_maps, system.static_coordinates(q))
    np.testing.assert_allclose(static, e0, rtol=0, atol=1e-9 * machine.bearings[0].clearance_m)


@pytest.mark.parametrize(
    ("forces", "override", "message"),
    [
        ([(13, 0.0, 90.0)], "", "static_forces[0].force_n must be > 0 N, got 0"),
        ([(99, 100.0, 90.0)], "", "static_forces[0].node"),
        (
            [(13, 100.0, 90.0)],
            "[[bearings.override]]\nnode = 20\nstatic_load_n = 4000.0\n",
            "give them, or a bearing's load (static_load_n, load_angle_deg: bearing 2), not both",
        ),
        ([(6, 3272.8248078, 0.0)], "", "bearing 1: the static forces and the weight cancel on it"),
    ],
)
def test_bad_static_forces_are_refused_in_one_line(tmp_path, forces, override, message):
    with pytest.raises(InputError, match=re.escape(message)) as error:
        with_forces(tmp_path, forces, "equal", override)
    assert "\n" not in str(error.value)
