"""The kind of film coefficients is a machine-file fact: synchronous K(Omega), C(Omega) by default, the
quasi-static ones on request, and every table, plant and estimator model follows it."""

from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from oilwatch.models.bearing.coefficient_kinds import QUASI_STATIC, SYNCHRONOUS, table_kind
from oilwatch.models.bearing.dynamic import FilmImpedance
from oilwatch.models.bearing.equilibrium import coefficients_at, static_equilibrium
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.supply import SupplyFlow
from oilwatch.models.bearing.table import compute_table
from oilwatch.models.machine import BUNDLED_MACHINE, load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.factory import build_system, flowrate_table_name, load_tables, table_command
from oilwatch.models.validation import InputError

TABLES = BUNDLED_MACHINE.parent / "tables"
LOAD_N = 3272.8248078061615


def _variant(tmp_path: Path, kind: str | None) -> Path:
    """The turbine's file with ``dynamic_coefficients`` set to ``kind`` (None: the key left out)."""
    line = "" if kind is None else f"dynamic_coefficients = {kind}\n"
    text = re.sub(r"(?m)^dynamic_coefficients = .*\n", line, BUNDLED_MACHINE.read_text(encoding="utf-8"))
    path = tmp_path / "turbine.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_the_turbine_and_a_file_without_the_key_use_the_synchronous_coefficients(tmp_path):
    assert load_machine().dynamic_coefficients == SYNCHRONOUS
    assert load_machine(_variant(tmp_path, None)).dynamic_coefficients == SYNCHRONOUS


def test_an_unknown_kind_is_a_one_line_error_naming_the_key(tmp_path):
    with pytest.raises(InputError, match=r"bearings.dynamic_coefficients must be one of .*got 'dynamic'"):
        load_machine(_variant(tmp_path, '"dynamic"'))


def test_table_names_and_commands_follow_the_kind(tmp_path):
    quasi = load_machine(_variant(tmp_path, '"quasi-static"'))
    assert flowrate_table_name(quasi, 75.0) == "turbine_bearing_75hz.json"
    assert flowrate_table_name(quasi, 75.0, SYNCHRONOUS) == "turbine_bearing_75hz_synchronous.json"
    assert table_command(quasi, 80.0, SYNCHRONOUS).endswith("--speed-hz 80 --coefficients synchronous")
    assert flowrate_table_name(load_machine(), 75.0) == "turbine_bearing_75hz_synchronous.json"


def test_the_plant_and_estimator_models_load_the_kind_of_the_machine_file(tmp_path):
    default = build_system(load_machine(), reduced=True)
    assert all(table_kind(t.metadata) == QUASI_STATIC for t in default.tables)  # the dynamics
    assert all(table_kind(t.metadata) == SYNCHRONOUS for t in default.synchronous_tables)  # the 1x load
    folder = tmp_path / "tables"
    folder.mkdir()
    shutil.copy(TABLES / "turbine_bearing_75hz.json", folder)
    quasi = build_system(load_machine(_variant(tmp_path, '"quasi-static"')), reduced=True)
    assert quasi.synchronous_tables is None
    assert all(table_kind(t.metadata) == QUASI_STATIC for t in quasi.tables)


@pytest.mark.parametrize("fraction", [1.0, 0.75])
def test_synchronous_model_has_the_synchronous_orbit_and_the_quasi_static_modes(fraction):
    machine = load_machine()
    q = tuple(fraction * machine.lubrication.nominal_flowrates_m3_s)
    hybrid = build_system(machine, reduced=False)
    pure = build_system(machine, reduced=False, table_path=TABLES / "turbine_bearing_75hz_synchronous.json")
    quasi = build_system(machine, reduced=False, coefficients=QUASI_STATIC)
    # The 1x orbit is the one of constant K(Omega), C(Omega) (within 1-2 % of the transient film) ...
    orbit = hybrid.bearing_positions(hybrid.unbalance_coordinates(q))
    np.testing.assert_allclose(orbit, pure.bearing_positions(pure.unbalance_coordinates(q)), rtol=1e-9)
    other = quasi.bearing_positions(quasi.unbalance_coordinates(q))
    assert np.abs(orbit - other).max() > 0.15 * np.abs(orbit).max()
    # ... and the free modes are the quasi-static ones: stable, where constant K(Omega), C(Omega) put a
    # mode near 50 Hz in the right half-plane below 95 % of nominal flow (the transient film's exact
    # roots at 75 Hz are stable, least log decrement 0.10-0.13).
    eig = np.linalg.eigvals(hybrid.state_space(q)[0])
    np.testing.assert_allclose(
        np.sort_complex(eig), np.sort_complex(np.linalg.eigvals(quasi.state_space(q)[0]))
    )
    assert eig.real.max() < 0
    if fraction < 0.95:
        assert np.linalg.eigvals(pure.state_space(q)[0]).real.max() > 0
    np.testing.assert_allclose(hybrid.static_coordinates(q), quasi.static_coordinates(q), rtol=1e-9)


def test_a_table_of_the_other_kind_under_the_expected_name_is_refused(tmp_path):
    machine = load_machine(_variant(tmp_path, '"quasi-static"'))
    folder = tmp_path / "tables"
    folder.mkdir()
    shutil.copy(TABLES / "turbine_bearing_75hz_synchronous.json", folder / "turbine_bearing_75hz.json")
    with pytest.raises(InputError, match=r"holds synchronous coefficients, the machine file asks for quasi"):
        load_tables(machine, Rotor.from_machine(machine), 75.0)


def test_compute_table_synchronous_rows_are_the_impedance_at_spin_speed():
    # One off-threshold flowrate on a coarse mesh: the table's row is Z(i Omega) of that equilibrium, and
    # its stiffness tends to the quasi-static (held partition) one only as omega -> 0, not at Omega.
    mesh = Mesh(60, 16)
    bearing, speed, q = load_machine().bearing, 75.0, 450e-6 / 60.0
    table = compute_table(bearing, LOAD_N, speed, [q, 1.1 * q], mesh, coefficients=SYNCHRONOUS)
    row = table.evaluate(q)
    eq = static_equilibrium(bearing, LOAD_N, speed, SupplyFlow(q), mesh)
    z = FilmImpedance(eq.film, eq.eccentricity_m, speed)
    k, c = z.coefficients(2 * math.pi * speed)
    np.testing.assert_allclose(row.stiffness, k, rtol=1e-6, atol=1e-6 * np.abs(k).max())
    np.testing.assert_allclose(row.damping, c, rtol=1e-6, atol=1e-6 * np.abs(c).max())
    k0, _ = coefficients_at(bearing, eq, speed, SupplyFlow(q), mesh)
    np.testing.assert_allclose(z.coefficients(1e-3)[0], k0, rtol=0, atol=2e-3 * np.abs(k0).max())
    assert table.metadata["solver"]["coefficients"].startswith("frequency-dependent")
    assert json.loads(json.dumps(table.to_dict()))["rows"][0]["stiffness_n_per_m"]["xx"] == pytest.approx(
        k[0, 0]
    )
