"""The machine-file loader: the bundled turbine, another machine, and every kind of bad input."""

from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pytest

from oilwatch.models.machine import BUNDLED_MACHINE, load_machine, machine_from_dict
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.validation import InputError

SMALL_MACHINE = """
[machine]
name = "three-bearing test rig"
nominal_speed_hz = 50.0
gravity_m_s2 = 9.81

[material]
youngs_modulus_pa = 200.0e9
poisson_ratio = 0.29
density_kg_m3 = 7800.0

[shaft]
element_length_mm = [100, 100, 100, 100, 100, 100]
element_diameter_mm = [50, 50, 50, 50, 50, 50]

[[discs]]
node = 3
width_mm = 20.0
outer_diameter_mm = 200.0

[unbalance]
iso_grade_mm_s = 6.3
node = 3
phase_deg = 90.0

[bearings]
nodes = [1, 4, 7]
load_split = "reactions"
radius_mm = 25.0
length_mm = 20.0
radial_clearance_um = 50.0
viscosity_pa_s = 0.03
groove_angle_deg = 0.0
groove_circumferential_mm = 5.0
groove_axial_mm = 10.0

[lubrication]
nominal_supply_pressure_bar = 1.0
nominal_flowrate_ml_min = 100.0
table_min_fraction_of_threshold = 0.5
table_max_fraction_of_threshold = 1.5
"""


@pytest.fixture(scope="module")
def turbine_dict():
    return tomllib.loads(BUNDLED_MACHINE.read_text())


def test_bundled_turbine_in_si_units():
    machine = load_machine()
    assert machine.n_elements == 20 and machine.n_nodes == 21
    assert machine.element_lengths_m.sum() == pytest.approx(2.235)
    assert machine.element_lengths_m[3] == pytest.approx(0.045)
    assert machine.element_diameters_m[10] == pytest.approx(0.2625)
    assert machine.bearing_nodes == (6, 20)
    assert [d.node for d in machine.discs] == [10, 13, 15]
    # The bore is the shaft diameter at the disc node (REFERENCE.md).
    assert [d.bore_diameter_m for d in machine.discs] == pytest.approx([0.1875, 0.1875, 0.165])
    assert machine.bearing.radius_m == pytest.approx(0.045)
    assert machine.bearing.clearance_m == pytest.approx(120e-6)
    assert machine.unbalance.iso_grade_m_s == pytest.approx(2.5e-3)
    assert machine.nominal_speed_rad_s == pytest.approx(2 * math.pi * 75)
    assert machine.shared_nominal_flowrate_m3_s("this test") * 6e7 == pytest.approx(596.3)
    assert machine.lubrication.nominal_supply_pressure_pa == pytest.approx(5e4)
    assert machine.structural_damping_s == pytest.approx(1e-5)
    with pytest.raises(ValueError):
        machine.element_lengths_m[0] = 1.0


def test_another_machine_file(tmp_path):
    path = tmp_path / "rig.toml"
    path.write_text(SMALL_MACHINE)
    machine = load_machine(path)
    assert machine.n_elements == 6 and machine.bearing_nodes == (1, 4, 7)
    assert machine.structural_damping_s == 0.0
    rotor = Rotor.from_machine(machine)
    assert rotor.n_dof == 28
    # Three rigid supports: statically indeterminate, but the reactions must carry the weight and
    # balance the moment about the left end.
    loads = rotor.bearing_static_loads_n
    assert loads.sum() == pytest.approx(rotor.weight_n, rel=1e-9)
    z = rotor.node_positions_m[[0, 3, 6]]
    disc_mass = rotor.discs[0][1].mass_kg
    moment = (rotor.shaft_mass_kg * 0.3 + disc_mass * 0.2) * rotor.gravity_m_s2
    assert loads @ z == pytest.approx(moment, rel=1e-9)


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (
            lambda d: d["shaft"]["element_length_mm"].__setitem__(3, -45.0),
            "shaft.element_length_mm[3] must be > 0 mm, got -45",
        ),
        (
            lambda d: d["shaft"]["element_diameter_mm"].__setitem__(0, "thirty"),
            "shaft.element_diameter_mm[0] must be a number",
        ),
        (lambda d: d["shaft"]["element_diameter_mm"].pop(), "has 20 entries"),
        (lambda d: d["discs"][1].__setitem__("node", 22), "discs[1].node = 22 is not a node"),
        (lambda d: d["bearings"]["nodes"].__setitem__(1, 0), "bearings.nodes[1] = 0 is not a node"),
        (lambda d: d["bearings"]["nodes"].__setitem__(1, 6), "must be distinct"),
        (lambda d: d["unbalance"].__setitem__("node", 2.5), "unbalance.node must be an integer"),
        (lambda d: d["material"].pop("density_kg_m3"), "missing material.density_kg_m3"),
        (lambda d: d["material"].__setitem__("poisson_ratio", 0.7), "material.poisson_ratio"),
        (lambda d: d["machine"].__setitem__("nominal_speed_hz", True), "must be a number"),
        (lambda d: d["machine"].__setitem__("nominal_speed_hz", -75.0), "must be > 0 Hz"),
        (lambda d: d.pop("lubrication"), "missing table [lubrication]"),
        (lambda d: d["bearings"].__setitem__("load_split", "static"), "bearings.load_split"),
        (lambda d: d["bearings"].__setitem__("radius_mm", 60.0), "does not match the shaft"),
        (lambda d: d["discs"][0].__setitem__("outer_diameter_mm", 100.0), "must exceed the shaft"),
        (lambda d: d["bearings"].__setitem__("radial_clearance_um", 5e4), "smaller than"),
        (lambda d: d["rotor_damping"].__setitem__("stiffness_proportional_s", -1.0), ">= 0 s"),
    ],
)
def test_bad_values_are_named(turbine_dict, mutate, message):
    data = copy.deepcopy(turbine_dict)
    mutate(data)
    with pytest.raises(InputError) as error:
        machine_from_dict(data)
    assert message in str(error.value)


def test_unreadable_files(tmp_path):
    with pytest.raises(InputError, match="cannot read machine file"):
        load_machine(tmp_path / "missing.toml")
    broken = tmp_path / "broken.toml"
    broken.write_text("[machine\nname = 1")
    with pytest.raises(InputError, match="not valid TOML"):
        load_machine(broken)


def test_two_bearing_reactions_match_statics():
    machine = load_machine()
    data = copy.deepcopy(dict(machine.raw))
    data["bearings"] = dict(data["bearings"], load_split="reactions")
    rotor = Rotor.from_machine(machine_from_dict(data))
    # Statically determinate: moment balance about bearing 1 with the rotor's centre of mass.
    z = rotor.node_positions_m
    lengths = machine.element_lengths_m
    shaft_masses = machine.material.density_kg_m3 * np.pi * machine.element_diameters_m**2 / 4 * lengths
    first_moment = shaft_masses @ (z[:-1] + lengths / 2) + sum(d.mass_kg * z[n - 1] for n, d in rotor.discs)
    z_cg = first_moment / rotor.total_mass_kg
    z1, z2 = z[5], z[19]
    expected_2 = rotor.weight_n * (z_cg - z1) / (z2 - z1)
    assert rotor.bearing_static_loads_n[1] == pytest.approx(expected_2, rel=1e-9)
    assert rotor.bearing_static_loads_n.sum() == pytest.approx(rotor.weight_n, rel=1e-9)


@pytest.mark.parametrize("name", ["turbine.toml", "compressor.toml"])
def test_without_tomllib_a_machine_file_is_read_from_its_parsed_twin(tmp_path, monkeypatch, name):
    """Python 3.10 has no tomllib: an FMU's bundled machine file is read from the twin its build wrote, the
    same machine; a twin of another text, or none, is a one-line error naming the file and Python 3.11."""
    import oilwatch.models.machine as machine_module

    source = tmp_path / name
    source.write_text((BUNDLED_MACHINE.parent / name).read_text())
    twin = machine_module.write_parsed_twin(source)
    assert twin.name == name + machine_module.PARSED_TWIN_SUFFIX
    expected = load_machine(source)
    monkeypatch.setattr(machine_module, "tomllib", None)
    read = load_machine(source)
    assert read.raw == expected.raw and read.name == expected.name
    np.testing.assert_array_equal(
        read.lubrication.nominal_flowrates_m3_s, expected.lubrication.nominal_flowrates_m3_s
    )
    np.testing.assert_array_equal(read.element_lengths_m, expected.element_lengths_m)
    source.write_text(source.read_text() + "\n# edited after the build\n")
    for _ in range(2):
        with pytest.raises(InputError) as error:
            load_machine(source)
        message = str(error.value)
        assert "\n" not in message and name in message and "Python 3.11" in message
        twin.unlink(missing_ok=True)
