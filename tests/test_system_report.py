"""The paper-reproduction report, the orbits and the fluid-film defaults of the rotor commands (issue 4)."""

import json

import numpy as np
import pytest

from oilwatch.cli import main
from oilwatch.models.bearing.equilibrium import coefficients_at, static_equilibrium
from oilwatch.models.bearing.grid import Mesh
from oilwatch.models.bearing.supply import SupplyFlow
from oilwatch.models.machine import load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.factory import load_speed_sweeps, load_system
from oilwatch.models.system.reproduction import paper_comparison

ROW_KEYS = {
    "interval_pct",
    "ecc_var_um_b1",
    "ecc_var_um_b2",
    "amp_x_var_um_b1",
    "amp_x_var_um_b2",
    "amp_y_var_um_b1",
    "amp_y_var_um_b2",
}


@pytest.fixture(scope="module")
def report():
    return paper_comparison()


@pytest.mark.slow
def test_report_has_the_documented_keys_and_rows(report):
    for key in (
        "rotor_weight_n",
        "flooded_threshold_ml_min",
        "nominal_flow_ml_min",
        "first_critical_hz",
        "instability_threshold_hz",
        "table4",
        "table5",
        "paper",
        "difference_pct",
        "definitions",
    ):
        assert key in report
    for table in ("table4", "table5"):
        assert [row["interval_pct"] for row in report[table]] == [
            "100-95",
            "95-90",
            "90-85",
            "85-80",
            "80-75",
        ]
        assert all(set(row) == ROW_KEYS for row in report[table])
    json.dumps(report)


@pytest.mark.slow
def test_report_figures_are_physically_consistent(report):
    assert report["rotor_weight_n"] == pytest.approx(6545.6, abs=0.5)
    # The paper's flows within 10 % (the expectation); q_t below the flow at 0.5 bar.
    assert report["flooded_threshold_ml_min"] == pytest.approx(546.0, rel=0.10)
    assert report["nominal_flow_ml_min"] == pytest.approx(596.3, rel=0.10)
    assert report["flooded_threshold_ml_min"] < report["nominal_flow_ml_min"]
    assert report["first_critical_hz"] == pytest.approx(55.0, rel=0.10)
    # Starvation pushes the journal out, more so the more starved: positive, growing steps.
    ecc = [row["ecc_var_um_b1"] for row in report["table4"]]
    assert all(e > 0 for e in ecc) and ecc == sorted(ecc)
    assert [row["ecc_var_um_b2"] for row in report["table4"]] == pytest.approx(ecc, abs=0.01)
    # With q2 nominal, bearing 2's eccentricity does not move (Table 5), bearing 1's as in Table 4.
    assert all(abs(row["ecc_var_um_b2"]) < 0.01 for row in report["table5"])
    assert [row["ecc_var_um_b1"] for row in report["table5"]] == pytest.approx(ecc, abs=0.01)


def test_table4_eccentricity_sums_to_the_table_equilibrium_shift():
    system = load_system(reduced=False)
    nominal = load_machine().shared_nominal_flowrate_m3_s("this test")
    table = system.tables[0]
    e_100 = np.hypot(*table.evaluate(nominal).eccentricity_m)
    e_75 = np.hypot(*table.evaluate(0.75 * nominal).eccentricity_m)
    orbit = [
        np.hypot(*system.bearing_positions(system.static_coordinates((f * nominal, f * nominal)))[0])
        for f in (1.0, 0.75)
    ]
    # The rotor's reactions differ from W/2 by 0.002 %: the bearing sits at the table's equilibrium.
    assert orbit[1] - orbit[0] == pytest.approx(e_75 - e_100, rel=1e-3)


@pytest.mark.slow
def test_a_speed_of_the_committed_sweep_is_recomputed():
    machine = load_machine()
    rotor = Rotor.from_machine(machine)
    sweep = load_speed_sweeps(machine, rotor)[0]
    i = int(np.flatnonzero(sweep.speeds_hz == 100.0)[0])
    mesh = Mesh(**sweep.provenance["mesh"])
    supply = SupplyFlow(sweep.flowrate_m3_s)
    eq = static_equilibrium(machine.bearing, sweep.load_n, 100.0, supply, mesh)
    stiffness, damping = coefficients_at(machine.bearing, eq, 100.0, supply, mesh)
    assert eq.eccentricity_m == pytest.approx(sweep.eccentricity_m[i], rel=1e-6, abs=1e-12)
    assert stiffness == pytest.approx(sweep.stiffness[i], rel=1e-3, abs=1e-3 * np.abs(stiffness).max())
    assert damping == pytest.approx(sweep.damping[i], rel=1e-3, abs=1e-3 * np.abs(damping).max())


@pytest.mark.slow
def test_report_and_orbits_commands(tmp_path, capsys):
    assert main(["report", "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["table4"][0]["interval_pct"] == "100-95"
    out = tmp_path / "orbits.png"
    assert main(["orbits", "--q-pct", "100", "80", "--out", str(out), "--json"]) == 0
    assert out.stat().st_size > 10_000
    orbits = json.loads(capsys.readouterr().out)["orbits"]
    assert orbits[1]["eccentricity_um"][0] > orbits[0]["eccentricity_um"][0]


def test_modes_use_the_fluid_film_by_default(capsys):
    assert main(["modes", "--json", "--q1-pct", "80"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["bearings"]["model"].startswith("fluid film")
    assert payload["bearings"]["q_ml_min"] == pytest.approx([0.8 * 596.3, 596.3])
    assert len(payload["modes"]) >= 8
    assert main(["modes", "--json", "--bearing-k", "1e8", "--bearing-c", "1e4"]) == 0
    assert json.loads(capsys.readouterr().out)["bearings"]["model"] == "linear isotropic"


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["modes", "--speed-hz", "100", "--q1-pct", "80"], "speed_hz = 100"),
        (["modes", "--q1-pct", "10"], "supply flowrate"),
        (["campbell", "--q2-pct", "90"], "--q1-pct/--q2-pct"),
        (["speed-sweep", "--speed-min-hz", "50", "--speed-max-hz", "40"], "--speed-max-hz"),
    ],
)
def test_bad_input_is_a_one_line_error(argv, named, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert named in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
