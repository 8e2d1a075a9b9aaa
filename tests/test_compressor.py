"""The second bundled machine: a six-stage compressor (the rotor of Timbo & Ritto 2019, ROSS's
compressor_example) on two-axial-groove bearings. Its file against its source, its committed tables against
direct solves, and its sudden drop through both FMUs against the demo's criteria."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from fixtures.doc_blocks import comparison_column
from fixtures.fmu_subprocess import REPO_ROOT
from fixtures.xdist_units import session_root

from oilwatch.cli.machine_comparison import DEMO_LABELS, MACHINE_LABELS, demo_cells
from oilwatch.cli.machine_option import MACHINE_HELP
from oilwatch.models.bearing.coefficient_kinds import SYNCHRONOUS
from oilwatch.models.bearing.equilibrium import coefficients_at, static_equilibrium
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.operating_accuracy import table_error
from oilwatch.models.bearing.operating_table import OperatingTable, operating_table_path
from oilwatch.models.bearing.supply import SupplyFlow
from oilwatch.models.bearing.table import CoefficientTable, compute_table
from oilwatch.models.machine import BUNDLED_MACHINES, bundled_name, load_machine, machine_file_path
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.factory import flowrate_table_path, machine_arguments

MACHINE = load_machine("compressor")
ROSS_ROTOR_MASS_KG = 246.8704
"""ROSS's compressor_example: its 91 shaft elements (rho pi/4 (od^2 - id^2) L) and 7 disk elements' masses."""


def test_the_compressor_is_bundled_by_name_and_carries_its_sources_mass():
    assert MACHINE.source_path == BUNDLED_MACHINES["compressor"]
    rotor = Rotor.from_machine(MACHINE)
    assert rotor.total_mass_kg == pytest.approx(ROSS_ROTOR_MASS_KG, rel=1e-4)  # dimensions to 0.1 mm
    first, second = MACHINE.bearing.grooves  # at the horizontal split line: half a turn apart
    assert second.angle_rad - first.angle_rad == pytest.approx(np.pi)
    table = CoefficientTable.load(flowrate_table_path(MACHINE, MACHINE.nominal_speed_hz))
    q_t = table.metadata["flooded_threshold_m3_s"]
    # the nominal supply (solved at the file's groove pressure) lies a little above the flooded threshold
    assert 1.05 < MACHINE.shared_nominal_flowrate_m3_s("this test") / q_t < 1.3


def test_a_bundled_machine_is_named_on_the_command_line_and_in_result_files(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert machine_file_path("compressor") == BUNDLED_MACHINES["compressor"]
    assert bundled_name(BUNDLED_MACHINES["compressor"]) == "compressor"
    assert bundled_name(tmp_path / "compressor.toml") is None and bundled_name(None) is None
    # the commands a message names: the default turbine without --machine, the compressor by its name
    assert machine_arguments(MACHINE) == ["--machine", "compressor"]
    assert machine_arguments(load_machine()) == []
    assert all(name in MACHINE_HELP for name in BUNDLED_MACHINES)  # --machine's help names each
    (tmp_path / "compressor").mkdir()  # a folder of that name does not hide the bundled machine
    assert machine_file_path("compressor") == BUNDLED_MACHINES["compressor"]
    (tmp_path / "compressor").rmdir()
    (tmp_path / "compressor").write_text("", encoding="utf-8")  # a file of that name here is the user's
    assert machine_file_path("compressor") == Path("compressor")


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["quasi-static", SYNCHRONOUS])
def test_a_row_of_each_committed_flowrate_table_is_reproduced(kind):
    table = CoefficientTable.load(flowrate_table_path(MACHINE, MACHINE.nominal_speed_hz, kind))
    mesh = Mesh(**table.metadata["mesh"])
    k = 2  # a starved row
    q = float(table.flowrates_m3_s[k])
    assert table.rows[k]["regime"] == "starved"
    if kind == SYNCHRONOUS:
        row = compute_table(
            MACHINE.bearing, table.load_n, table.speed_hz, [q, 1.1 * q], mesh, coefficients=kind
        )
        stiffness, damping, eccentricity = row.stiffness[0], row.damping[0], row.eccentricity_m[0]
    else:
        eq = static_equilibrium(MACHINE.bearing, table.load_n, table.speed_hz, SupplyFlow(q), mesh)
        stiffness, damping = coefficients_at(MACHINE.bearing, eq, table.speed_hz, SupplyFlow(q), mesh)
        eccentricity = eq.eccentricity_m
    np.testing.assert_allclose(eccentricity, table.eccentricity_m[k], rtol=1e-6)
    np.testing.assert_allclose(stiffness, table.stiffness[k], rtol=1e-4, atol=1e-6 * np.abs(stiffness).max())
    np.testing.assert_allclose(damping, table.damping[k], rtol=1e-4, atol=1e-6 * np.abs(damping).max())


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["quasi-static", SYNCHRONOUS])
def test_the_dimensionless_tables_reproduce_a_direct_solve_off_their_nodes(kind):
    path = operating_table_path(MACHINE.source_path, kind)
    table = OperatingTable.load(path)
    table.check_geometry(MACHINE.bearing)
    mesh = Mesh(**table.metadata["mesh"])
    load = Rotor.from_machine(MACHINE).bearing_static_loads_n[0]
    # 110 Hz and 0.8 of the nominal viscosity: between Sommerfeld nodes; 0.8 q_t: between flowrate nodes
    err = table_error(table, MACHINE.bearing, 110.0, 0.8 * MACHINE.bearing.viscosity_pa_s, load, 0.8, mesh)
    assert err.stiffness < 0.01 and err.damping < 0.01 and err.eccentricity_ratio < 0.005


@pytest.mark.slow
def test_the_sudden_drop_on_the_compressor_meets_the_demos_criteria(tmp_path_factory, tmp_path):
    """oilwatch demo --machine compressor: both FMUs built for the compressor, 100 -> 75 % of its nominal
    flowrate at 1 um noise: errors after the drop under 2 %, both alarms within 2 s, no false alarm."""
    cache = session_root(tmp_path_factory) / "oilwatch_cache"
    environment = dict(
        os.environ, OPENBLAS_NUM_THREADS="1", OILWATCH_CACHE=str(cache), PYTHONPATH=str(REPO_ROOT)
    )
    out = tmp_path / "demo"
    command = ["demo", "--machine", "compressor", "--out", str(out), "--no-progress"]
    process = subprocess.run(
        [sys.executable, "-m", "oilwatch", *command],
        cwd=REPO_ROOT, env=environment, capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert process.returncode == 0, process.stdout + process.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["parameters"]["plant"]["machine_file"] == str(BUNDLED_MACHINES["compressor"])
    for b in (1, 2):
        assert summary[f"q{b}_err_pct_after"] < 2.0
        assert 0.0 <= summary[f"alarm_delay_s_b{b}"] <= 2.0
        assert summary[f"false_alarm_s_b{b}"] is None
    labels = MACHINE_LABELS + DEMO_LABELS
    assert comparison_column("compressor")[len(MACHINE_LABELS) : len(labels)] == demo_cells(summary)
