"""Bearings of one machine may differ: ``[[bearings.override]]`` in the machine file, one geometry per bearing
in :class:`oilwatch.models.machine.Machine`, tables per distinct geometry, a system whose bearings each
have their own film coefficients (checked against a direct solve of each bearing), and each bearing's own
flowrate range in the plant and the estimator. The whole chain through both FMUs on a machine whose bearings
differ: tests/test_second_machine.py."""

from __future__ import annotations

import json
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from fixtures.toy_model import NOMINAL_FLOWRATE_M3_S, TABLE_BOUNDS_M3_S, ToyRotor, simulate

from oilwatch.cli import main
from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.fmu_src.ekf_configuration import flowrates_ml_min
from oilwatch.models.bearing.centreline import load_loci
from oilwatch.models.bearing.coefficient_kinds import QUASI_STATIC
from oilwatch.models.bearing.equilibrium import coefficients_at, static_equilibrium
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.operating_table import operating_table_path
from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S, SupplyFlow
from oilwatch.models.bearing.table import compute_table, flooded_threshold
from oilwatch.models.machine import BUNDLED_MACHINES, load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.augmented import GridAugmentedModel
from oilwatch.models.system.clearance import machine_loci
from oilwatch.models.system.factory import (
    build_system,
    flowrate_table_name,
    flowrate_table_path,
    load_speed_sweeps,
    load_tables,
    locus_table_name,
    locus_table_path,
    speed_sweep_name,
    speed_sweep_path,
    table_command,
)
from oilwatch.models.system.fault import SigmoidFlowrate
from oilwatch.models.system.operating_point import operating_system
from oilwatch.models.system.plant import RotorBearingPlant
from oilwatch.models.system.speed_sweep import compute_speed_sweep
from oilwatch.models.system.structure import PlantStructure, structural_system
from oilwatch.models.validation import InputError
from oilwatch.records.writers import write_record

TURBINE = Path(__file__).resolve().parents[1] / "models" / "turbine.toml"
NON_DRIVE_END = """
[[bearings.override]]
node = 20
length_mm = 60.0
radial_clearance_um = 110.0
groove_angle_deg = 0.0
groove_circumferential_mm = 14.0
groove_axial_mm = 30.0
"""
"""Bearing 2 of the test machine: shorter, of a smaller clearance and a smaller groove; its flooded threshold
is bearing 1's within 2 % (534 and 541 ml/min on :data:`MESH`)."""
FAR_APART = """
[[bearings.override]]
node = 20
radial_clearance_um = 155.0
"""
"""Bearing 2 of a larger clearance: its flooded threshold is twice bearing 1's (1073 and 542 ml/min on
:data:`MESH`), so that each bearing's tables span flowrates outside the other's."""
MESH = Mesh(40, 10)
"""A coarse film mesh: the tables of the system test in seconds."""


def machine_file(folder: Path, overrides: str = NON_DRIVE_END, stem: str = "two", **keys: str) -> Path:
    """The bundled turbine with ``overrides`` after its [bearings] table (and ``keys`` of [bearings] set to
    the TOML values given), written to ``folder/<stem>.toml``."""
    text = TURBINE.read_text(encoding="utf-8")
    for key, value in keys.items():
        text = re.sub(rf"(?m)^{key} = .*$", f"{key} = {value}", text)
    text = text.replace("\n[oil]\n", f"\n{overrides}\n[oil]\n", 1)
    path = folder / f"{stem}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_an_override_gives_one_bearing_its_own_geometry(tmp_path):
    turbine = load_machine(None)
    machine = load_machine(machine_file(tmp_path))
    drive_end, non_drive_end = machine.bearings
    assert drive_end == turbine.bearing  # bearing 1 keeps the [bearings] geometry
    assert non_drive_end.length_m == pytest.approx(0.060)
    assert non_drive_end.clearance_m == pytest.approx(110e-6)
    assert (non_drive_end.groove_circumferential_m, non_drive_end.groove_axial_m) == pytest.approx(
        (0.014, 0.030)
    )
    assert (
        non_drive_end.radius_m == drive_end.radius_m
        and non_drive_end.viscosity_pa_s == drive_end.viscosity_pa_s
    )
    assert machine.bearings_differ and machine.distinct_geometries == (0, 1)
    assert [machine.geometry_bearing(i) for i in (0, 1)] == [1, 2]
    with pytest.raises(InputError, match=r"bearings of .* differ .*takes one bearing geometry") as error:
        machine.bearing  # noqa: B018 (the property refuses)
    assert "\n" not in str(error.value)


def test_an_override_may_give_several_grooves_and_a_circumferential_groove(tmp_path):
    overrides = """
[[bearings.override]]
node = 6
circumferential_groove_axial_mm = 10.0

[[bearings.override.grooves]]
angle_deg = 90.0
circumferential_mm = 14.0
axial_mm = 28.0

[[bearings.override.grooves]]
angle_deg = 270.0
circumferential_mm = 14.0
axial_mm = 28.0
"""
    machine = load_machine(machine_file(tmp_path, overrides))
    drive_end, non_drive_end = machine.bearings
    assert non_drive_end == load_machine(None).bearing
    assert np.degrees(drive_end.groove_angle_rad) == pytest.approx(90.0)
    assert [np.degrees(g.angle_rad) for g in drive_end.more_grooves] == pytest.approx([270.0])
    assert drive_end.circumferential_groove_m == pytest.approx(0.010)
    assert drive_end.length_m == non_drive_end.length_m  # not overridden: the [bearings] length


def test_an_override_of_the_shared_values_leaves_the_bearings_alike_and_the_table_names_as_they_are(tmp_path):
    same = "\n[[bearings.override]]\nnode = 20\nlength_mm = 70.0\nradial_clearance_um = 120.0\n"
    machine = load_machine(machine_file(tmp_path, same))
    assert not machine.bearings_differ and machine.bearing == load_machine(None).bearing
    assert flowrate_table_name(machine, 75.0, bearing_index=1) == "two_bearing_75hz_synchronous.json"


@pytest.mark.parametrize("name", sorted(BUNDLED_MACHINES))
def test_every_bundled_machine_has_alike_bearings_and_its_table_names(name):
    machine = load_machine(name)
    assert len(machine.bearings) == len(machine.bearing_nodes) and not machine.bearings_differ
    assert all(b is machine.bearing for b in machine.bearings)  # one geometry object, as [bearings] gives it
    assert machine.distinct_geometries == (0,)
    speed = machine.nominal_speed_hz
    for index in range(len(machine.bearings)):
        assert flowrate_table_name(machine, speed, QUASI_STATIC, index) == f"{name}_bearing_{speed:g}hz.json"
        assert locus_table_name(machine, index) == f"{name}_bearing_locus.json"
        assert speed_sweep_name(machine, "full-film", index) == f"{name}_speed_sweep.json"
        assert "--bearing" not in table_command(machine, speed, QUASI_STATIC, index)
        assert flowrate_table_path(machine, speed, QUASI_STATIC, index).is_file()  # the committed tables
    assert operating_table_path(machine.source_path).name == f"{name}_bearing_dimensionless.json"


def test_differing_bearings_have_tables_named_after_their_geometrys_first_bearing(tmp_path):
    machine = load_machine(machine_file(tmp_path))
    assert flowrate_table_name(machine, 75.0, bearing_index=0) == "two_bearing1_75hz_synchronous.json"
    assert flowrate_table_name(machine, 75.0, QUASI_STATIC, 1) == "two_bearing2_75hz.json"
    assert locus_table_name(machine, 1) == "two_bearing2_locus.json"
    assert speed_sweep_name(machine, "everywhere", 1) == "two_bearing2_speed_sweep_squeeze_everywhere.json"
    assert (
        operating_table_path(machine.source_path, QUASI_STATIC, 2).name == "two_bearing2_dimensionless.json"
    )
    command = f"oilwatch bearing-table --machine {machine.source_path} --speed-hz 75 --bearing 2"
    assert table_command(machine, 75.0, bearing_index=1) == command
    with pytest.raises(InputError, match=re.escape(f"`{command.replace(' --bearing 2', ' --bearing 1')}`")):
        load_tables(machine, Rotor.from_machine(machine), 75.0)


BAD_OVERRIDES = [
    ("node = 7", r"^bearings\.override\[0\]\.node must be one of bearings\.nodes \[6, 20\], got 7$"),
    (
        "node = 20\nviscosity_pa_s = 0.05",
        r"^bearings\.override\[0\]\.viscosity_pa_s cannot differ between bearings",
    ),
    ("node = 20\nlength_mm = 0.0", r"^bearings\.override\[0\]\.length_mm must be > 0 mm, got 0$"),
    (
        "node = 20\nradius_mm = 40.0",
        r"^bearings\.override\[0\]\.radius_mm = 40 does not match the shaft at bearings",
    ),
    (
        "node = 20\nradial_clearance_um = 45000.0",
        r"^bearings\.override\[0\]\.radial_clearance_um must be smaller",
    ),
    (
        "node = 20\nlength_mm = 30.0",
        r"^bearings\.groove_axial_mm must be <= bearings\.override\[0\]\.length_mm",
    ),
    ("node = 20\ngroove_axial_mm = 30.0", r"^missing bearings\.override\[0\]\.groove_circumferential_mm$"),
    ("node = 20\ncircumferential_groove_axial_mm = 80.0", r"circumferential_groove_axial_mm must be < 70 mm"),
    (
        "node = 20\nnominal_flowrate_ml_min = -5.0",
        r"^bearings\.override\[0\]\.nominal_flowrate_ml_min must be > 0 ml/min, got -5$",
    ),
    (
        'node = 20\nnominal_flowrate_ml_min = "lots"',
        r"^bearings\.override\[0\]\.nominal_flowrate_ml_min must be a number, got 'lots'$",
    ),
]


@pytest.mark.parametrize(
    ("entry", "message"), BAD_OVERRIDES, ids=[e.split("\n")[-1] for e, _ in BAD_OVERRIDES]
)
def test_a_bad_override_is_refused_in_one_line_naming_its_key(tmp_path, entry, message):
    with pytest.raises(InputError) as error:
        load_machine(machine_file(tmp_path, f"[[bearings.override]]\n{entry}\n"))
    text = str(error.value)
    assert "\n" not in text
    assert re.search(message, text.split(": ", 1)[1] if text.startswith("machine file") else text), text


def test_two_overrides_of_one_bearing_are_refused(tmp_path):
    twice = "[[bearings.override]]\nnode = 20\n\n[[bearings.override]]\nnode = 20\n"
    with pytest.raises(InputError, match=r"bearings\.override\[1\]\.node = 20: that bearing has an override"):
        load_machine(machine_file(tmp_path, twice))


def with_tables(folder: Path, overrides: str) -> tuple:
    """The machine of ``overrides`` (quasi-static coefficients) in ``folder`` with a small table per bearing
    at 75 Hz, each of its geometry at its load on :data:`MESH` (0.5, 0.8, 1.2 and 1.5 times its flooded
    threshold): (machine, the tables' flowrates per bearing)."""
    machine = load_machine(machine_file(folder, overrides, dynamic_coefficients='"quasi-static"'))
    loads = Rotor.from_machine(machine).bearing_static_loads_n
    (folder / "tables").mkdir()
    flows = []
    for index, (bearing, load) in enumerate(zip(machine.bearings, loads, strict=True)):
        q_t, _ = flooded_threshold(bearing, load, 75.0, MESH)
        q = q_t * np.array([0.5, 0.8, 1.2, 1.5])
        compute_table(bearing, load, 75.0, q, MESH).save(
            flowrate_table_path(machine, 75.0, bearing_index=index)
        )
        flows.append(q)
    return machine, flows


@pytest.fixture(scope="module")
def differing(tmp_path_factory):
    """The two-bearing machine of :data:`NON_DRIVE_END` with its tables (:func:`with_tables`)."""
    return with_tables(tmp_path_factory.mktemp("per_bearing"), NON_DRIVE_END)


def test_a_system_of_differing_bearings_has_each_bearings_own_coefficients(differing):
    """Each bearing's table at its nodes against a direct p-theta solve of that bearing (same mesh), and the
    two bearings' coefficients apart by far more than that."""
    machine, flows = differing
    system = build_system(machine, reduced=False)
    assert [t.metadata["bearing"]["clearance_m"] for t in system.tables] == [
        b.clearance_m for b in machine.bearings
    ]
    for index, (bearing, load) in enumerate(zip(machine.bearings, system.static_loads_n, strict=True)):
        for q in flows[index][1:3]:
            eq = static_equilibrium(bearing, load, 75.0, SupplyFlow(q), MESH)
            stiffness, damping = coefficients_at(bearing, eq, 75.0, SupplyFlow(q), MESH)
            row = system.tables[index].evaluate(q)
            assert np.allclose(row.stiffness, stiffness, rtol=1e-6, atol=1e-6 * np.abs(stiffness).max())
            assert np.allclose(row.damping, damping, rtol=1e-6, atol=1e-6 * np.abs(damping).max())
            assert np.allclose(row.eccentricity_m, eq.eccentricity_m, rtol=1e-6, atol=1e-12)
    q = machine.shared_nominal_flowrate_m3_s("this test")
    one, two = (system.tables[b].evaluate(q) for b in (0, 1))
    assert np.abs(one.stiffness - two.stiffness).max() > 0.1 * np.abs(one.stiffness).max()


def test_a_system_of_differing_bearings_sits_and_runs_on_each_bearings_film(differing):
    """Statics: each journal at its own bearing's equilibrium under its load, the two apart; a plant on the
    system steps with finite outputs and each bearing's own eccentricity ratio."""
    machine, _ = differing
    system = build_system(machine, reduced=False)
    q = machine.shared_nominal_flowrate_m3_s("this test")
    positions = system.bearing_positions(system.static_coordinates((q, q)))
    for index in (0, 1):
        expected = system.tables[index].evaluate(q).eccentricity_m
        assert np.allclose(positions[index], expected, rtol=1e-3, atol=1e-3 * np.linalg.norm(expected))
    assert np.linalg.norm(positions[1] - positions[0]) > 0.05 * np.linalg.norm(positions[0])
    plant = RotorBearingPlant(system, 1e-3, None, 0.0, 1, initial_flowrates_m3_s=(q, q))
    samples = [plant.step((q, 0.9 * q)) for _ in range(20)]
    assert all(np.isfinite(s.measured_position_m).all() for s in samples)
    journals = samples[-1].true_position_m.reshape(2, 2)
    clearances = [b.clearance_m for b in machine.bearings]  # each bearing's own e / c
    assert samples[-1].eccentricity_ratio == pytest.approx(np.linalg.norm(journals, axis=1) / clearances)


def test_a_table_of_another_geometry_is_refused_naming_the_command_that_makes_the_right_one(
    differing, tmp_path
):
    machine, _ = differing
    rotor = Rotor.from_machine(machine)
    wrong = load_tables(machine, rotor, 75.0)[0]
    other = load_machine(machine_file(tmp_path, dynamic_coefficients='"quasi-static"'))
    (tmp_path / "tables").mkdir()
    for index in (0, 1):
        wrong.save(flowrate_table_path(other, 75.0, bearing_index=index))
    command = f"oilwatch bearing-table --machine {other.source_path} --speed-hz 75 --bearing 2"
    with pytest.raises(InputError) as error:
        load_tables(other, rotor, 75.0)
    assert "computed for length_m = 0.07, the bearing has 0.06 (bearing 2 (node 20))" in str(error.value)
    assert str(error.value).endswith(f"recompute it with `{command}`")


def test_bearing_table_makes_one_table_per_distinct_geometry_and_bearing_n_only_its_own(tmp_path, capsys):
    path = machine_file(tmp_path, dynamic_coefficients='"quasi-static"')
    coarse = ("--mesh", "40", "10", "--points", "3", "--quiet")
    assert main(["bearing-table", "--machine", str(path), *coarse]) == 0
    made = sorted(p.name for p in (tmp_path / "tables").iterdir())
    assert made == ["two_bearing1_75hz.json", "two_bearing2_75hz.json"]
    machine = load_machine(path)
    tables = load_tables(machine, Rotor.from_machine(machine), 75.0)
    assert [t.metadata["bearing"]["length_m"] for t in tables] == [b.length_m for b in machine.bearings]
    assert tables[1].metadata["provenance"]["command_line"].endswith("--bearing 2")
    (tmp_path / "tables" / "two_bearing2_75hz.json").unlink()
    assert main(["bearing-table", "--machine", str(path), *coarse, "--bearing", "2"]) == 0
    assert sorted(p.name for p in (tmp_path / "tables").iterdir()) == made
    capsys.readouterr()
    assert main(["bearing-table", "--machine", str(path), *coarse, "--out", str(tmp_path / "one.json")]) == 2
    assert "--out takes one table, and the bearings of" in capsys.readouterr().err
    assert main(["bearing-table", "--machine", str(path), *coarse, "--bearing", "3"]) == 2
    assert (
        "--bearing must be a bearing number 1..2 (bearings.nodes [6, 20]), got 3" in capsys.readouterr().err
    )


def test_oilwatch_bearing_solves_bearing_n(tmp_path, capsys):
    path = str(machine_file(tmp_path))
    args = ("bearing", "--machine", path, "--q-ml-min", "596.3", "--json", "--mesh", "40", "10")
    results = []
    for number in ("1", "2"):
        assert main([*args, "--bearing", number]) == 0
        results.append(json.loads(capsys.readouterr().out))
    machine = load_machine(path)
    load = float(Rotor.from_machine(machine).bearing_static_loads_n[1])
    supply = SupplyFlow(596.3 / ML_MIN_PER_M3_S)
    eq = static_equilibrium(machine.bearings[1], load, 75.0, supply, MESH)
    assert results[1]["eccentricity_ratio"] == pytest.approx(eq.eccentricity_ratio, rel=1e-9)
    assert abs(results[1]["eccentricity_ratio"] / results[0]["eccentricity_ratio"] - 1.0) > 0.1


@pytest.fixture(scope="module")
def mapped(tmp_path_factory):
    """The two-bearing machine (quasi-static coefficients) with a small dimensionless table per bearing
    geometry from ``oilwatch bearing-map`` (3 x 3 nodes on :data:`MESH`, about the nominal point)."""
    folder = tmp_path_factory.mktemp("per_bearing_map")
    path = machine_file(folder, dynamic_coefficients='"quasi-static"')
    ranges = ("--speed-range", "0.9", "1.1", "--viscosity-range", "0.9", "1.1", "--sommerfeld-ratio", "1.6")
    argv = [
        "bearing-map",
        "--machine",
        str(path),
        "--mesh",
        "40",
        "10",
        "--fractions",
        "3",
        *ranges,
        "--quiet",
    ]
    assert main(argv) == 0
    return load_machine(path)


def test_bearing_map_makes_a_table_per_geometry_and_the_operating_plant_uses_each(mapped):
    """The plant on the dimensionless tables (:func:`operating_system`) and the structural plant: each
    bearing's coefficients at a table node (nominal speed, viscosity and load; 1.5 q_t) against a direct solve
    of that bearing on the same mesh."""
    names = sorted(p.name for p in (mapped.source_path.parent / "tables").glob("*_dimensionless.json"))
    assert names == ["two_bearing1_dimensionless.json", "two_bearing2_dimensionless.json"]
    viscosity = mapped.bearings[0].viscosity_pa_s
    for system in (
        operating_system(mapped, 75.0, viscosity),
        structural_system(mapped, PlantStructure(film_coefficients=QUASI_STATIC)),
    ):
        for index, (bearing, load) in enumerate(zip(mapped.bearings, system.static_loads_n, strict=True)):
            q_t, _ = flooded_threshold(bearing, load, 75.0, MESH)
            supply = SupplyFlow(1.5 * q_t)
            eq = static_equilibrium(bearing, load, 75.0, supply, MESH)
            stiffness, _ = coefficients_at(bearing, eq, 75.0, supply, MESH)
            row = system.tables[index].evaluate(1.5 * q_t)
            assert np.allclose(row.stiffness, stiffness, rtol=1e-4, atol=1e-4 * np.abs(stiffness).max())
            assert np.allclose(
                row.eccentricity_m, eq.eccentricity_m, rtol=1e-4, atol=1e-4 * bearing.clearance_m
            )


def test_the_estimator_finds_each_bearings_flowrate_on_differing_bearings(differing):
    """The EKF (recommended tuning) on the reduced grid model against the full-model plant, 1 um noise, with
    0.9 and 1.1 x the nominal flowrate: measured when written, +0.12 % and +0.04 % after 3 s, std 0.26 and
    0.40 %."""
    machine, _ = differing
    q = machine.shared_nominal_flowrate_m3_s("this test")
    truth = np.array([0.9 * q, 1.1 * q])
    plant = RotorBearingPlant(
        build_system(machine, reduced=False), 1e-3, None, 1e-6, 3, initial_flowrates_m3_s=truth
    )
    data = np.array([plant.step(truth).measured_position_m for _ in range(3000)])
    model = GridAugmentedModel(build_system(machine, reduced=True), 1e-3)
    trace = OilFlowEKF(model, EKFConfig.recommended(first_sample_time_s=1e-3)).run(data)
    assert np.abs(trace.q_m3_s[-1] / truth - 1.0).max() < 0.01
    assert np.abs(trace.q_m3_s[-1] - truth).max() < 3.0 * trace.q_std_m3_s[-1].max()


def test_oilwatch_estimate_on_the_machine_preset_finds_each_bearings_flowrate(mapped, tmp_path):
    """``oilwatch estimate`` (the default preset: the dimensionless tables, unbalance and viscosity factors
    estimated) on a 4 s record of the plant on the dimensionless tables, 1 um noise, 0.9 and 1.1 x nominal:
    measured when written, 535.6 and 650.4 ml/min for 536.7 and 655.9, std 34 and 37 ml/min, trusted."""
    path = mapped.source_path
    assert (
        main(["bearing-table", "--machine", str(path), "--mesh", "40", "10", "--points", "5", "--quiet"]) == 0
    )
    q = mapped.shared_nominal_flowrate_m3_s("this test")
    truth = np.array([0.9 * q, 1.1 * q])
    plant = RotorBearingPlant(
        operating_system(mapped, 75.0, mapped.bearings[0].viscosity_pa_s), 1e-3, None, 1e-6, 3,
        initial_flowrates_m3_s=truth,
    )  # fmt: skip
    measured = np.array([plant.step(truth).measured_position_m for _ in range(4000)])
    columns = {"time_s": 1e-3 * np.arange(1, 4001)}
    columns |= {f"{n}_um": measured[:, i] * 1e6 for i, n in enumerate(("x1", "y1", "x2", "y2"))}
    record = write_record(tmp_path / "two.csv", columns)
    out = tmp_path / "out"
    assert (
        main(
            [
                "estimate",
                str(record),
                "--machine",
                str(path),
                "--out",
                str(out),
                "--no-progress",
                "--no-views",
            ]
        )
        == 0
    )
    summary = json.loads((out / "summary.json").read_text())
    found = np.array([summary["q1_final_ml_min"], summary["q2_final_ml_min"]]) / ML_MIN_PER_M3_S
    spread = np.array([summary["q1_std_final_ml_min"], summary["q2_std_final_ml_min"]]) / ML_MIN_PER_M3_S
    assert np.all(np.abs(found - truth) < spread) and np.all(np.abs(found / truth - 1.0) < 0.02)
    assert summary["trust"]["trusted"]


def test_a_speed_sweep_of_another_geometry_is_refused_naming_the_command_that_makes_the_right_one(differing):
    machine, _ = differing
    rotor = Rotor.from_machine(machine)
    load = float(rotor.bearing_static_loads_n[0])
    q = machine.shared_nominal_flowrate_m3_s("this test")
    sweep = compute_speed_sweep(machine.bearings[0], load, [70.0, 75.0], q, MESH)
    for index in (0, 1):
        sweep.save(speed_sweep_path(machine, bearing_index=index))
    with pytest.raises(InputError) as error:
        load_speed_sweeps(machine, rotor)
    assert "computed for length_m = 0.07, the bearing has 0.06 (bearing 2 (node 20))" in str(error.value)
    assert str(error.value).endswith(f"`oilwatch speed-sweep --machine {machine.source_path} --bearing 2`")


def test_bearing_locus_makes_a_locus_per_geometry_and_the_clearance_fit_takes_each_bearings(tmp_path):
    path = machine_file(tmp_path)
    assert main(["bearing-locus", "--machine", str(path), "--mesh", "40", "10"]) == 0
    machine = load_machine(path)
    files = [locus_table_path(machine, index) for index in (0, 1)]
    assert [f.name for f in files] == ["two_bearing1_locus.json", "two_bearing2_locus.json"]
    loci = machine_loci(machine)  # from the files: nothing solved on the production mesh
    for index, (locus, file) in enumerate(zip(loci, files, strict=True)):
        assert locus.to_dict() == load_loci(file)[0].to_dict()
        pressure = machine.lubrication.nominal_supply_pressure_pa
        load = float(Rotor.from_machine(machine).bearing_static_loads_n[index])
        assert locus.matches(machine.bearings[index], load, pressure)
        assert not locus.matches(machine.bearings[1 - index], load, pressure)


@pytest.fixture(scope="module")
def far_apart(tmp_path_factory):
    """The two-bearing machine of :data:`FAR_APART` with its tables (:func:`with_tables`)."""
    return with_tables(tmp_path_factory.mktemp("far_apart"), FAR_APART)


def _thresholds(flows) -> list[float]:
    """Each bearing's flooded threshold [m^3/s]: twice its table's first flowrate (:func:`with_tables`)."""
    return [q[0] / 0.5 for q in flows]


def _ranges_ml_min(flows) -> list[str]:
    """Each bearing's table range as the errors print it: ``[low, high]`` [ml/min]."""
    return [f"[{q[0] * ML_MIN_PER_M3_S:.1f}, {q[-1] * ML_MIN_PER_M3_S:.1f}]" for q in flows]


def test_each_bearings_flowrate_range_is_its_own_tables_and_its_grid_axis_spans_it(far_apart):
    """Flooded thresholds 542 and 1073 ml/min: the tables' common span (537-812 ml/min) was the estimator's
    one range before; each bearing's is now its own table's, and so is its axis of the flowrate grid."""
    machine, flows = far_apart
    system = build_system(machine, reduced=True)
    own = np.array([[q[0], q[-1]] for q in flows])
    np.testing.assert_array_equal(system.bearing_flowrate_bounds_m3_s, own)
    assert own[1, 0] > 1.9 * own[0, 0] and own[1, 1] > 1.9 * own[0, 1]
    grid = GridAugmentedModel(system, 1e-3).grid
    for nodes, (low, high) in zip((grid.q1_nodes_m3_s, grid.q2_nodes_m3_s), own, strict=True):
        assert (nodes[0], nodes[-1]) == (low, high)


def test_the_plant_refuses_a_bearings_flowrate_outside_its_own_range_naming_it(far_apart):
    """Bearing 2's flooded threshold lies in its own table but past bearing 1's, and 0.9 times bearing 1's
    below bearing 2's: each refused for the bearing it is given to, in one line with that bearing's range."""
    machine, flows = far_apart
    system = build_system(machine, reduced=False)
    inside = (flows[0][1], flows[1][1])
    q_t = _thresholds(flows)
    high_for_one, low_for_two = q_t[1], 0.9 * q_t[0]
    one, two = _ranges_ml_min(flows)
    q1 = f"{high_for_one * ML_MIN_PER_M3_S:.1f}"
    with pytest.raises(InputError) as error:
        RotorBearingPlant(system, 1e-3, None, 0.0, 1, initial_flowrates_m3_s=(high_for_one, inside[1]))
    assert (
        str(error.value)
        == f"q1 input = {q1} ml/min lies outside bearing 1's coefficient table range {one} ml/min"
    )
    plant = RotorBearingPlant(system, 1e-3, None, 0.0, 1, initial_flowrates_m3_s=inside)
    with pytest.raises(
        InputError,
        match=rf"^q2 input = .* outside bearing 2's coefficient table range {re.escape(two)} ml/min$",
    ):
        plant.step((inside[0], low_for_two))
    fault = (
        SigmoidFlowrate(inside[0], inside[0], 1.0, 0.2),
        SigmoidFlowrate(inside[1], low_for_two, 1.0, 0.2),
    )
    with pytest.raises(InputError, match=r"^q2 final = .* outside bearing 2's"):
        RotorBearingPlant(system, 1e-3, fault, 0.0, 1)


def test_the_filter_holds_each_flowrate_within_its_own_bearings_range():
    """The toy with bearing 1's range cut to 0.9 of nominal, bearing 1 at that bound and bearing 2 at nominal:
    bearing 1's estimate is projected onto its own bound at times, never past it, while bearing 2's is past
    it, at nominal (2 %, as the toy's estimate at a table edge); a start outside a bearing's own range is
    refused naming the bearing."""
    toy = ToyRotor()
    cut = 0.9 * NOMINAL_FLOWRATE_M3_S
    toy.bearing_flowrate_bounds_m3_s = np.array([(TABLE_BOUNDS_M3_S[0], cut), TABLE_BOUNDS_M3_S])
    with pytest.raises(
        InputError, match=r"^EKFConfig\.q_initial_m3_s of bearing 1 must lie in its table range"
    ):
        OilFlowEKF(toy, EKFConfig.recommended())
    truth = np.array([cut, NOMINAL_FLOWRATE_M3_S])
    record = simulate(toy, np.tile(truth, (3000, 1)), 1e-6, seed=21)
    config = EKFConfig.recommended(q_initial_m3_s=(0.8 * NOMINAL_FLOWRATE_M3_S, NOMINAL_FLOWRATE_M3_S))
    trace = OilFlowEKF(toy, config).run(record.displacement_m)
    assert trace.q_m3_s[:, 0].max() == cut and (trace.q_m3_s[:, 0] == cut).any()
    assert np.abs(trace.q_m3_s[-1000:] / truth - 1.0).max() < 0.02


def test_oilwatch_estimate_finds_each_bearings_flowrate_outside_the_other_bearings_range(far_apart, tmp_path):
    """``oilwatch estimate --preset paper`` (the reduced grid model, nuisances known) on a 3 s record of the
    full-model plant, 1 um noise, 0.9 times bearing 1's flooded threshold (487 ml/min, below bearing 2's
    table) and bearing 2's threshold (1073 ml/min, above bearing 1's): before, the plant refused the first
    and the estimator's one range (537-812 ml/min) held neither. Measured when written: -0.05 and +0.02 %,
    std 0.30 and 0.18 %, trusted. Tolerance: 3 of the filter's own stds (its model is consistent with the
    data) and 1 % (the reduced grid model against the full-model plant, as for the alike bearings)."""
    machine, flows = far_apart
    q_t = _thresholds(flows)
    truth = np.array([0.9 * q_t[0], q_t[1]])
    assert truth[0] < flows[1][0] and truth[1] > flows[0][-1]
    plant = RotorBearingPlant(
        build_system(machine, reduced=False), 1e-3, None, 1e-6, 3, initial_flowrates_m3_s=truth
    )
    measured = np.array([plant.step(truth).measured_position_m for _ in range(3000)])
    columns = {"time_s": 1e-3 * np.arange(1, 3001)}
    columns |= {f"{n}_um": measured[:, i] * 1e6 for i, n in enumerate(("x1", "y1", "x2", "y2"))}
    record = write_record(tmp_path / "far.csv", columns)
    out = tmp_path / "out"
    path = str(machine.source_path)
    argv = ["estimate", str(record), "--machine", path, "--out", str(out), "--preset", "paper"]
    assert main([*argv, "--no-progress", "--no-views"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    found = np.array([summary["q1_final_ml_min"], summary["q2_final_ml_min"]]) / ML_MIN_PER_M3_S
    spread = np.array([summary["q1_std_final_ml_min"], summary["q2_std_final_ml_min"]]) / ML_MIN_PER_M3_S
    assert np.all(np.abs(found - truth) < 3.0 * spread) and np.all(np.abs(found / truth - 1.0) < 0.01)
    assert summary["trust"]["trusted"]
    limits = summary["trust"]["table_limits_ml_min"]
    for b, q in enumerate(flows):
        low, high = limits[f"bearing{b + 1}"]
        assert q[0] * ML_MIN_PER_M3_S < low < high < q[-1] * ML_MIN_PER_M3_S  # each own, a small margin in
        assert high - low > 0.99 * (q[-1] - q[0]) * ML_MIN_PER_M3_S


def test_the_estimator_fmu_checks_its_initial_flowrate_against_each_bearings_range(far_apart):
    machine, flows = far_apart
    system = build_system(machine, reduced=True)
    one, two = _ranges_ml_min(flows)
    nominal = machine.shared_nominal_flowrate_m3_s("this test") * ML_MIN_PER_M3_S
    unset = {f"q{b}_{kind}_ml_min": 0.0 for b in (1, 2) for kind in ("nominal", "initial")}
    assert flowrates_ml_min(SimpleNamespace(**unset), system) == ((nominal, nominal), (nominal, nominal))
    for initial, bearing, text in ((900.0, 1, one), (500.0, 2, two)):
        slave = SimpleNamespace(**{**unset, f"q{bearing}_initial_ml_min": initial})
        with pytest.raises(InputError) as error:
            flowrates_ml_min(slave, system)
        assert str(error.value) == (
            f"q{bearing}_initial_ml_min must lie in bearing {bearing}'s coefficient table range {text} "
            f"ml/min, got {initial:g} ml/min"
        )
