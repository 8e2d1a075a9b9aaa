"""``oilwatch bearing`` and ``oilwatch bearing-table``, in-process: JSON schema, output, errors."""

from __future__ import annotations

import json

import pytest

from oilwatch.cli import main
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.table import CoefficientTable, flooded_threshold
from oilwatch.models.machine import load_machine

COARSE = ("--mesh", "60", "16")
KEYS = {
    "q_ml_min",
    "regime",
    "supply_pressure_pa",
    "eccentricity_ratio",
    "attitude_deg",
    "e_x_um",
    "e_y_um",
    "side_leakage_ml_min",
    "K_N_per_m",
    "C_Ns_per_m",
}


def run_cli(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_bearing_json_by_flowrate(capsys):
    code, out, _ = run_cli(capsys, "bearing", "--q-ml-min", "596.3", "--json", *COARSE)
    assert code == 0
    data = json.loads(out)
    assert set(data) == KEYS
    assert data["q_ml_min"] == pytest.approx(596.3)
    assert data["regime"] in ("flooded", "starved")
    assert data["side_leakage_ml_min"] == pytest.approx(596.3, rel=1e-6)
    for block in ("K_N_per_m", "C_Ns_per_m"):
        assert set(data[block]) == {"xx", "xy", "yx", "yy"}
        assert all(isinstance(v, float) for v in data[block].values())
    assert data["e_y_um"] < 0.0 < data["e_x_um"]


def test_bearing_json_by_pressure_zero_gives_the_threshold(capsys):
    code, out, _ = run_cli(capsys, "bearing", "--supply-pressure-bar", "0", "--json", *COARSE)
    assert code == 0
    data = json.loads(out)
    assert set(data) == KEYS
    machine = load_machine()
    q_t, _ = flooded_threshold(machine.bearing, 3272.8248, 75.0, Mesh(60, 16))
    assert data["q_ml_min"] == pytest.approx(q_t * 6e7, rel=1e-5)
    assert data["supply_pressure_pa"] == 0.0


def test_bearing_readable_table(capsys):
    code, out, _ = run_cli(capsys, "bearing", "--supply-pressure-bar", "0.5", *COARSE)
    assert code == 0
    assert "eccentricity ratio" in out and "stiffness K [N/m]" in out and "0.5000 bar" in out


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (("--q-ml-min", "-5"), "--q-ml-min must be > 0"),
        (("--supply-pressure-bar", "-0.1"), "--supply-pressure-bar must be >= 0"),
        (("--q-ml-min", "500", "--speed-hz", "0"), "--speed-hz must be > 0"),
        (("--q-ml-min", "500", "--mesh", "8", "4"), "mesh n_circ must be >= 24"),
    ],
)
def test_bearing_bad_input_exits_2_naming_the_argument(capsys, argv, named):
    code, out, err = run_cli(capsys, "bearing", *argv)
    assert code == 2
    assert named in err
    assert out == "" and "Traceback" not in err


def test_bearing_table_command_writes_a_loadable_table(capsys, tmp_path):
    out_file = tmp_path / "table.json"
    plot = tmp_path / "table.png"
    code, out, err = run_cli(
        capsys,
        "bearing-table",
        "--points",
        "3",
        "--speed-hz",
        "60",
        "--mesh",
        "48",
        "12",
        "--out",
        str(out_file),
        "--plot",
        str(plot),
        "--quiet",
    )
    assert code == 0 and out == ""
    table = CoefficientTable.load(out_file)
    assert table.speed_hz == 60.0
    assert len(table.rows) == 3
    assert "bearing-table" in table.metadata["provenance"]["command_line"]
    assert plot.stat().st_size > 10_000
    assert "q_t =" in err
