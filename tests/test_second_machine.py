"""oilwatch for another machine, with bearings that differ, from the installed package, in an empty folder.

The ``oilwatch`` command of the environment running the tests (CI installs the project from the clone, not
editable: the package pip built and installed, as a user's ``pip install``) runs with no PYTHONPATH in an
empty temporary folder: a second machine file there (the bundled turbine with a 150 um clearance, its oil
supplied at 40 instead of 30.8 degC, no nominal flowrate: each bearing's is computed at the file's 0.5 bar
groove pressure with its own geometry and load, and a non-drive-end bearing of its own, shorter, tighter and
with a smaller groove, whose static load the file gives: 4000 N along 160 deg, a belt's pull beside the
weight) goes through ``oilwatch bearing-table --machine M2.toml`` (a table per bearing
geometry) and ``oilwatch demo --machine M2.toml`` (the sudden drop, 100 -> 75 % of each bearing's nominal
flowrate, through both FMUs built with those tables; its summary.json is the one ``oilwatch run
sudden-drop`` writes). What the wheel holds is tests/test_wheel.py's.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
from fixtures.second_bearing import NON_DRIVE_END
from fixtures.venvs import REPO_ROOT, clean_env

from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S
from oilwatch.models.machine import load_machine

pytestmark = pytest.mark.slow


def second_machine(folder) -> str:
    """M2.toml in ``folder``: the turbine with another clearance and oil, nominal flowrate from pressure, and
    its bearing 2 of its own geometry and static load."""
    text = (REPO_ROOT / "models" / "turbine.toml").read_text(encoding="utf-8")
    text = re.sub(r"(?m)^name = .*$", 'name = "turbine M2 (150 um, oil at 40 degC)"', text)
    text = re.sub(r"(?m)^radial_clearance_um = .*$", "radial_clearance_um = 150.0", text)
    text, supplies = re.subn(
        r"(?m)^nominal_supply_temperature_c = .*$", "nominal_supply_temperature_c = 40.0", text
    )
    assert supplies == 1
    text = re.sub(r"(?m)^nominal_flowrate_ml_min = .*\n", "", text)
    # bearing 2 scaled from tests/test_per_bearing.py's, its load given: the plant carries the external
    # force that turns its weight share (3273 N down) into it, the tables are solved for it
    side_load = "load_angle_deg = 160.0\nstatic_load_n = 4000.0\n"
    text = text.replace("\n[oil]\n", "\n" + NON_DRIVE_END + side_load + "\n[oil]\n", 1)
    (folder / "M2.toml").write_text(text, encoding="utf-8")
    return "M2.toml"


def test_a_second_machine_runs_end_to_end_from_the_installed_package_in_an_empty_folder(tmp_path, capsys):
    oilwatch = Path(sys.executable).parent / "oilwatch"
    work = tmp_path / "empty"
    work.mkdir()
    machine_file = second_machine(work)
    env = clean_env(OPENBLAS_NUM_THREADS="1", OILWATCH_CACHE=str(tmp_path / "cache"), MPLBACKEND="Agg")

    def oilwatch_command(*arguments):
        start = time.perf_counter()
        process = subprocess.run(
            [str(oilwatch), *arguments], cwd=work, env=env, capture_output=True, text=True, timeout=1800
        )
        return process, time.perf_counter() - start

    table, table_s = oilwatch_command("bearing-table", "--machine", machine_file, "--quiet")
    assert table.returncode == 0, table.stderr
    for n in (1, 2):  # the default kind, one per bearing geometry
        assert (work / "tables" / f"M2_bearing{n}_75hz_synchronous.json").is_file()
    demo, demo_s = oilwatch_command("demo", "--machine", machine_file, "--out", "d")
    assert demo.returncode == 0, demo.stdout + demo.stderr[-3000:]
    summary = json.loads((work / "d" / "summary.json").read_text(encoding="utf-8"))
    # each bearing's own nominal, bearing 2 of its own geometry
    nominal = load_machine(work / machine_file).lubrication.nominal_flowrates_m3_s * ML_MIN_PER_M3_S
    plant = summary["parameters"]["plant"]
    for b, q in enumerate(nominal, start=1):
        assert plant[f"q{b}_initial_ml_min"] == pytest.approx(q, rel=1e-6)
        assert summary["parameters"]["ekf"][f"q{b}_nominal_ml_min"] == pytest.approx(q, rel=1e-6)
    assert plant["q1_final_ml_min"] == pytest.approx(0.75 * nominal[0], rel=1e-6)
    for b in (1, 2):
        assert summary[f"q{b}_err_pct_after"] < 2.0
        assert summary[f"alarm_delay_s_b{b}"] is not None and summary[f"false_alarm_s_b{b}"] is None
    where = subprocess.run(
        [sys.executable, "-c", "import oilwatch; print(oilwatch.__file__)"],
        cwd=work, env=env, capture_output=True, text=True, check=True,
    )  # fmt: skip
    package = Path(where.stdout.strip()).parent
    assert not list((package / "models" / "tables").glob("M2*"))  # nothing written into the package
    with capsys.disabled():
        print(
            f"\nsecond machine (nominal {nominal[0]:.1f} / {nominal[1]:.1f} ml/min): bearing-table "
            f"{table_s:.0f} s, demo {demo_s:.0f} s (simulation {summary['wall_s']:.1f} s, set-up "
            f"{summary['setup_s']:.1f} s); errors after {summary['q1_err_pct_after']:.2f} / "
            f"{summary['q2_err_pct_after']:.2f} %"
        )
