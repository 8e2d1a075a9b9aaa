"""Machine facts come from the machine file: nominal flowrate (given or computed from the supply pressure),
the scenarios' flowrates and speed, where tables are looked for and written, and the advice naming the one
command that makes a missing table."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from fixtures.toy_model import ToyRotor

from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S
from oilwatch.models.machine import BUNDLED_MACHINE, load_machine
from oilwatch.models.rotor.assembly import Rotor
from oilwatch.models.system.factory import (
    flowrate_table_path,
    load_speed_sweeps,
    load_tables,
    speed_sweep_path,
    table_command,
)
from oilwatch.models.validation import InputError
from oilwatch.scenarios import make_run
from oilwatch.study import make_cases


def _variant(tmp_path: Path, **replacements: str) -> Path:
    text = BUNDLED_MACHINE.read_text(encoding="utf-8")
    for key, value in replacements.items():
        pattern = rf"(?m)^{key} = .*\n"
        text = re.sub(pattern, "" if value is None else f"{key} = {value}\n", text)
    path = tmp_path / "variant.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_the_bundled_turbine_keeps_the_papers_nominal_flowrate():
    machine = load_machine()
    assert list(machine.lubrication.nominal_flowrates_m3_s * ML_MIN_PER_M3_S) == pytest.approx([596.3] * 2)
    assert machine.lubrication.nominal_flowrates_computed == (False, False)


def test_a_file_without_a_flowrate_gets_it_from_the_supply_pressure(tmp_path):
    """The paper's definition: the steady flow at 0.5 bar groove pressure. REFERENCE.md: an independent
    p-theta solver gives 601.9 (140 x 40) to 610.4 ml/min (280 x 80) against the paper's 596.3."""
    machine = load_machine(_variant(tmp_path, nominal_flowrate_ml_min=None))
    assert machine.lubrication.nominal_flowrates_computed == (True, True)
    assert 598.0 < machine.shared_nominal_flowrate_m3_s("this test") * ML_MIN_PER_M3_S < 622.0


def test_a_file_with_neither_flowrate_nor_pressure_is_refused(tmp_path):
    path = _variant(tmp_path, nominal_flowrate_ml_min=None, nominal_supply_pressure_bar=None)
    with pytest.raises(InputError, match="nominal_flowrate_ml_min or nominal_supply_pressure_bar"):
        load_machine(path)


def test_scenarios_and_study_cases_use_the_machines_nominal_flowrate_and_speed(tmp_path):
    machine = load_machine(_variant(tmp_path, nominal_flowrate_ml_min="800.0", nominal_speed_hz="80.0"))
    run = make_run("clog-b1", machine=machine)
    assert run.q1_ml_min == (800.0, 600.0) and run.q2_ml_min == (800.0, 1000.0)
    assert run.plant_parameters()["speed_hz"] == run.ekf_parameters()["speed_hz"] == 80.0
    assert run.ekf_parameters()["q1_nominal_ml_min"] == run.ekf_parameters()["q2_nominal_ml_min"] == 800.0
    assert run.plant_parameters()["machine_file"] == str(machine.source_path.resolve())
    assert run.starving(1) and not run.starving(2)
    faster = make_run("sudden-drop", machine=machine, overrides={"plant": {"speed_hz": 85.0}})
    assert faster.plant_parameters()["speed_hz"] == faster.ekf_parameters()["speed_hz"] == 85.0
    case = make_cases([1.0], grid_step_pct=25.0, machine=machine)[-1]
    expected = (75.0, 600.0, str(machine.source_path.resolve()))
    assert (case.q1_pct, case.q1_ml_min, case.machine_file) == expected
    bundled = make_run("sudden-drop")
    assert bundled.plant_parameters()["machine_file"] == "" and bundled.q1_ml_min[0] == pytest.approx(596.3)


def test_a_missing_table_of_the_bundled_turbine_is_looked_for_in_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("OILWATCH_CACHE", str(tmp_path))
    machine = load_machine()
    assert flowrate_table_path(machine, 75.0).parent == BUNDLED_MACHINE.parent / "tables"  # committed
    missing = flowrate_table_path(machine, 80.0)
    assert missing == tmp_path / "tables" / "turbine_bearing_80hz_synchronous.json"  # never the package
    with pytest.raises(InputError, match=r"`oilwatch bearing-table --speed-hz 80`"):
        load_tables(machine, Rotor.from_machine(machine), 80.0)


def test_advice_for_a_users_machine_names_the_machine(tmp_path):
    machine = load_machine(_variant(tmp_path))
    rotor = Rotor.from_machine(machine)
    assert flowrate_table_path(machine, 75.0) == tmp_path / "tables" / "variant_bearing_75hz_synchronous.json"
    command = table_command(machine, 75.0)
    assert command == f"oilwatch bearing-table --machine {machine.source_path} --speed-hz 75"
    with pytest.raises(InputError, match=re.escape(command)):
        load_tables(machine, rotor, 75.0)
    assert speed_sweep_path(machine).parent == tmp_path / "tables"
    with pytest.raises(InputError, match=re.escape(f"oilwatch speed-sweep --machine {machine.source_path}")):
        load_speed_sweeps(machine, rotor)


def test_the_filter_reports_progress_through_a_callback():
    calls = []
    OilFlowEKF(ToyRotor()).run(np.zeros((250, 4)), progress=lambda done, total: calls.append((done, total)))
    assert calls[0] == (0, 250) and calls[-1] == (250, 250)
