"""Misuse found by trying (issue 12, item 6): each gives one line naming the input and what is allowed,
exit code 2, and leaves no stale output beside new output. The CLI cases run ``oilwatch.cli.main`` in
this process where no FMU is loaded; those that need the FMUs run in fresh processes."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from types import SimpleNamespace

import pytest
from fixtures.fmu_subprocess import REPO_ROOT, run_json

from oilwatch.cli import main
from oilwatch.cli.run import parameter_labels, parse_settings
from oilwatch.cosim.errors import SystemDescriptionError
from oilwatch.cosim.values import FMI2_INTEGER_RANGE, fmi_value
from oilwatch.models.bearing.table import CoefficientTable
from oilwatch.models.machine import BUNDLED_MACHINE, load_machine
from oilwatch.models.validation import InputError
from oilwatch.outputs import interrupts
from oilwatch.outputs.atomic import write_json_atomic
from oilwatch.outputs.lock import output_lock

TABLE = BUNDLED_MACHINE.parent / "tables" / "turbine_bearing_75hz.json"


def one_line_error(capsys, argv: list[str]) -> str:
    """Run the CLI; assert exit code 2 and a single stderr line; return it."""
    try:
        code = main(argv)
    except SystemExit as stop:  # argparse's own errors
        code = stop.code
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


# ------------------------------------------------------------------ values for FMU variables
def variable(kind, minimum=None, maximum=None, unit=None):
    return SimpleNamespace(type=kind, minimum=minimum, maximum=maximum, unit=unit)


def test_integer_parameters_are_integers_within_32_bits_and_their_declared_range():
    seed = variable("Integer", minimum="0")
    assert fmi_value(seed, 7, "--seed") == 7 and fmi_value(seed, 7.0, "--seed") == 7
    assert fmi_value(seed, FMI2_INTEGER_RANGE[1], "--seed") == 2**31 - 1
    for value in (4294967296, 2147483648, -1, 1.5, "abc", True, float("nan")):
        with pytest.raises(SystemDescriptionError) as error:
            fmi_value(seed, value, "--seed")
        assert str(error.value) == f"--seed must be an integer in [0, 2147483647], got {value!r}"
    channels = variable("Integer", minimum="0", maximum="2")
    with pytest.raises(
        SystemDescriptionError, match=r"^--set ekf.velocity_channels must be an integer in \[0, 2\]"
    ):
        fmi_value(channels, 1.5, "--set ekf.velocity_channels")


def test_real_text_and_boolean_values_are_checked_by_type():
    hold = variable("Real", minimum="0", maximum="60", unit="s")
    assert fmi_value(hold, 2, "x") == 2 and fmi_value(hold, "0.5", "x") == 0.5
    for value in ("abc", float("inf"), None, False):
        with pytest.raises(
            SystemDescriptionError, match=r"^--set ekf.alarm_hold_on_s must be a number in \[0, 60\] s"
        ):
            fmi_value(hold, value, "--set ekf.alarm_hold_on_s")
    flag = variable("Boolean")
    assert fmi_value(flag, "true", "b") is True and fmi_value(flag, 0, "b") is False
    with pytest.raises(SystemDescriptionError, match="must be a Boolean"):
        fmi_value(flag, "yes please", "b")


def test_set_values_keep_integers_and_are_labelled_by_their_flag():
    given = parse_settings(["ekf.velocity_channels=1", "ekf.alarm_hold_on_s=0.5", "plant.flow_source=table"])
    assert given == {
        "ekf": {"velocity_channels": 1, "alarm_hold_on_s": 0.5},
        "plant": {"flow_source": "table"},
    }
    assert isinstance(given["ekf"]["velocity_channels"], int)
    labels = parameter_labels("constant", given, {"velocity_channels": 1, "q_std_velocity_um_s": 10.0})
    assert labels["plant"]["q1_initial_ml_min"] == "--q1-pct" and labels["plant"]["seed"] == "--seed"
    assert labels["ekf"]["velocity_channels"] == "--set ekf.velocity_channels"  # --set wins
    assert labels["ekf"]["q_std_velocity_um_s"] == "--paper-tuning"
    assert "sudden-drop" in parameter_labels("sudden-drop", {}, {})["plant"]["q1_final_ml_min"]


# ------------------------------------------------------------------ the command line
def test_argument_errors_are_one_line(capsys):
    line = one_line_error(capsys, ["run", "constant", "--seed", "abc"])
    assert line.startswith("oilwatch run: error: argument --seed: invalid int value: 'abc'")
    assert "oilwatch run --help" in line


@pytest.mark.parametrize(
    ("option", "named"),
    [(["--workers", "0"], "--workers must be an integer >= 1"), (["--scheduler", "nowhere"], "--scheduler")],
)
def test_cluster_options_are_checked_with_one_record_too(capsys, tmp_path, option, named):
    """One record runs in this process, but a bad cluster option is still the user's error, not ignored."""
    record = tmp_path / "record.csv"
    record.write_text("time_s,x1_um,y1_um,x2_um,y2_um\n0,0,0,0,0\n0.001,0,0,0,0\n")
    line = one_line_error(capsys, ["estimate", str(record), "--out", str(tmp_path / "out"), *option])
    assert named in line and not (tmp_path / "out").exists()


def test_out_onto_a_file_or_a_folder_is_refused_before_any_work(capsys, tmp_path):
    a_file = tmp_path / "a_file"
    a_file.write_text("keep me")
    line = one_line_error(capsys, ["run", "constant", "--out", str(a_file)])
    assert (
        line
        == f"oilwatch run: error: --out '{a_file}' is an existing file; give a folder (created if missing)"
    )
    line = one_line_error(capsys, ["study", "--out", str(a_file / "inside")])
    assert f"'{a_file}' is a file, so no folder can be made inside it" in line
    line = one_line_error(capsys, ["orbits", "--out", str(tmp_path)])
    assert line == f"oilwatch orbits: error: --out '{tmp_path}' is a folder; give a file name inside it"
    line = one_line_error(capsys, ["bearing-table", "--plot", str(a_file / "t.png")])
    assert line.startswith("oilwatch bearing-table: error: --plot ")
    assert a_file.read_text() == "keep me"
    line = one_line_error(capsys, ["run", "nonsense", "--out", str(tmp_path / "new" / "run")])
    assert "scenario 'nonsense' is unknown" in line and not (tmp_path / "new").exists()  # nothing made


def test_out_into_missing_folders_creates_them(tmp_path):
    from oilwatch.cli.outputs import output_file, output_folder

    assert output_folder("--out", tmp_path / "a" / "b").is_dir()
    assert output_file("--out", tmp_path / "c" / "d" / "plot.png").parent.is_dir()


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"", "is empty"),
        (b"   \n", "is empty"),
        (bytes(range(256)), "is not a text file (binary data at byte 0)"),
        (b"\xac\xed\x00\x05 serialized", "is not a text file"),
        (b'[machine]\nname = "x"\n', "missing table [material]"),
    ],
)
def test_bad_machine_files_are_named(capsys, tmp_path, content, message):
    path = tmp_path / "m2.toml"
    path.write_bytes(content)
    with pytest.raises(InputError) as error:
        load_machine(path)
    assert str(path) in str(error.value) and message in str(error.value)
    line = one_line_error(capsys, ["rotor", "--machine", str(path)])
    assert line.startswith("oilwatch rotor: error: machine file") and str(path) in line


def _broken_table(tmp_path: Path, mutate) -> Path:
    """A copy of the bundled machine with a coefficient table broken by ``mutate``; the machine file."""
    tables = tmp_path / "tables"
    tables.mkdir()
    machine = tmp_path / "turbine.toml"
    machine.write_text(BUNDLED_MACHINE.read_text())
    data = json.loads(TABLE.read_text())
    mutate(data)
    (tables / TABLE.name).write_text(json.dumps(data))
    return machine


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d["rows"][2]["damping_n_s_per_m"].pop("yx"), "rows[2].damping_n_s_per_m has no key 'yx'"),
        (lambda d: d["rows"][0].pop("regime"), "rows[0] has no key 'regime'"),
        (lambda d: d["rows"][1].__setitem__("attitude_deg", "wide"), "rows[1].attitude_deg must be a number"),
        (lambda d: d["rows"].__setitem__(3, [1, 2]), "rows[3] must be an object"),
        (lambda d: d.__setitem__("rows", {"a": 1}), "the table.rows must be a list"),
        (lambda d: d.pop("load_n"), "the table has no key 'load_n'"),
    ],
)
def test_a_coefficient_table_of_the_wrong_structure_is_named(capsys, tmp_path, mutate, message):
    machine = _broken_table(tmp_path, mutate)
    table = tmp_path / "tables" / TABLE.name
    with pytest.raises(InputError) as error:
        CoefficientTable.load(table)
    assert str(error.value) == f"coefficient table '{table}': {message}" or (
        str(table) in str(error.value) and message in str(error.value)
    ), error.value
    line = one_line_error(capsys, ["modes", "--machine", str(machine)])
    assert str(table) in line and message in line


def test_a_speed_sweep_of_the_wrong_shape_is_named(tmp_path):
    from oilwatch.models.system.speed_sweep import SpeedSweep

    data = json.loads((TABLE.parent / "turbine_speed_sweep.json").read_text())
    data["stiffness_n_per_m"] = data["stiffness_n_per_m"][:-1]
    path = tmp_path / "sweep.json"
    path.write_text(json.dumps(data))
    with pytest.raises(InputError, match=r"sweep.json: stiffness_n_per_m must be finite numbers of shape \("):
        SpeedSweep.load(path)


# ------------------------------------------------------------------ stale outputs of an interrupted run
def test_a_run_that_starts_removes_the_previous_runs_files_and_keeps_its_own_rows(tmp_path):
    """The scenario runner's recorder: the previous run's files go when the new run's recording starts
    (all FMUs initialized; summary.json then says the run is not complete), the rows written before a
    stop stay (the end-to-end Ctrl-C case is in test_cli_run; a run refused at initialization keeps the
    previous files: the slow test below)."""
    from oilwatch.cosim import CsvRecorder
    from oilwatch.scenarios.runner import OUTPUT_FILES, _StopBetweenSteps

    for name in OUTPUT_FILES:
        (tmp_path / name).write_text("previous run\n")
    stale = tuple(tmp_path / name for name in OUTPUT_FILES)
    recorder = _StopBetweenSteps(CsvRecorder(tmp_path / "result.csv"), stale)
    recorder.start(["q1"])
    recorder.record(0.0, [596.3])
    with pytest.raises(KeyboardInterrupt), interrupts.held():
        os.kill(os.getpid(), signal.SIGTERM)  # held back until the row is whole
        recorder.record(0.001, [596.3])
    recorder.close()
    assert sorted(path.name for path in tmp_path.iterdir()) == ["result.csv", "summary.json"]
    assert json.loads((tmp_path / "summary.json").read_text())["completed"] is False
    assert (tmp_path / "result.csv").read_text().splitlines()[1:] == ["0.0,596.3", "0.001,596.3"]


# ------------------------------------------------------------------ two studies in one folder
HOLDER = """
import sys, time
from pathlib import Path
from oilwatch.outputs.lock import output_lock
with output_lock(Path(sys.argv[1]), "study"):
    print("locked", flush=True)
    time.sleep(60)
"""


def test_a_second_study_into_the_same_folder_is_refused_and_a_dead_holders_lock_taken_over(tmp_path, capsys):
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(tmp_path)],
        cwd=REPO_ROOT,
        env=dict(os.environ, PYTHONPATH=str(REPO_ROOT)),
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(InputError) as error:
            with output_lock(tmp_path, "estimate"):
                pass
        assert f"oilwatch study (pid {holder.pid}, started " in str(error.value)
        assert "is writing this folder" in str(error.value)
        line = one_line_error(
            capsys, ["study", "--out", str(tmp_path), "--case", "synthetic", "--workers", "1"]
        )
        assert f"(pid {holder.pid}, started " in line and not (tmp_path / "cases.csv").exists()
    finally:
        holder.kill()
        holder.wait()
    assert json.loads((tmp_path / "oilwatch.lock").read_text())["pid"] == holder.pid  # killed: it stays
    with output_lock(tmp_path, "study"):
        assert json.loads((tmp_path / "oilwatch.lock").read_text())["pid"] == os.getpid()
    assert (tmp_path / "oilwatch.lock").read_text() == ""


def test_concurrent_atomic_writes_never_lose_their_temporary_file(tmp_path):
    path = tmp_path / "study.json"
    errors = []

    def writer(k):
        try:
            for i in range(200):
                write_json_atomic(path, {"writer": k, "i": i})
        except Exception as error:  # the old shared 'study.json.tmp' raised FileNotFoundError here
            errors.append(error)

    threads = [threading.Thread(target=writer, args=(k,)) for k in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    assert json.loads(path.read_text())["i"] == 199
    assert [p.name for p in tmp_path.iterdir()] == ["study.json"]


# ------------------------------------------------------------------ FMUs: values, labels, set after init
def test_master_names_the_input_as_the_user_gave_it(toys):
    result = run_json(
        f"""
from oilwatch.cosim import FmuSpec, Master, SlaveError, SystemDescription, SystemDescriptionError
system = SystemDescription([FmuSpec("plant", {str(toys / "ToyPlant.fmu")!r}, {{}})])
result = {{}}
for name, params, labels in [
    ("seed", {{"seed": 4294967296}}, {{"seed": "--seed"}}),
    ("unlabelled", {{"seed": 1.5}}, {{}}),
    ("text", {{"noise_um": "abc"}}, {{"noise_um": "--noise-um"}}),
    ("fmu_log", {{"noise_um": -1.0}}, {{"noise_um": "--noise-um"}}),
]:
    try:
        with Master(system) as master:
            master.run(stop_time=0.01, step_size=1e-3, parameters={{"plant": params}},
                       labels={{"plant": labels}})
        result[name] = "ran"
    except (SlaveError, SystemDescriptionError) as error:
        result[name] = type(error).__name__ + ": " + str(error)
"""
    )
    assert (
        result["seed"]
        == "SystemDescriptionError: --seed must be an integer in [0, 2147483647], got 4294967296"
    )
    assert result["unlabelled"].startswith("SystemDescriptionError: plant.seed must be an integer in [0, ")
    assert result["text"].startswith("SystemDescriptionError: --noise-um must be a number")
    assert result["fmu_log"].startswith("SlaveError: FMU instance 'plant': fmi2ExitInitializationMode")
    assert "--noise-um (noise_um) must" in result["fmu_log"], result["fmu_log"]


# A fixed parameter set after initialization (fmi2Error, the instance steps on): tests/test_fmi_set_status.py


@pytest.mark.slow
def test_misused_run_flags_give_one_line_naming_the_flag(built_fmus, tmp_path):
    """The real FMUs: each misuse is refused before a row is written, naming the flag."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(REPO_ROOT))
    cases = [
        (["--set", "ekf.alarm_hold_on_s=abc"], "--set ekf.alarm_hold_on_s must be a number in [0, "),
        (["--set", "ekf.velocity_channels=1.5"], "--set ekf.velocity_channels must be an integer in [0, 1]"),
        (["--seed", "4294967296"], "--seed must be an integer in [0, 2147483647], got 4294967296"),
        (["--seed", "2147483648"], "--seed must be an integer in [0, 2147483647], got 2147483648"),
        (["--q1-pct", "20"], "--q1-pct (q1_initial_ml_min) = "),
        # an input the run would ignore (the schedule drives the flowrates) is refused, not ignored
        (["--set", "plant.q1_in_ml_min=1"], "--set plant.q1_in_ml_min (q1_in_ml_min) = 1.0 is ignored while"),
    ]
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text("{}\n")  # a previous run's: kept, no new run started
    for args, message in cases:
        start = time.perf_counter()
        process = subprocess.run(
            [sys.executable, "-m", "oilwatch", "run", "constant", "--fmu-dir", str(built_fmus),
             "--out", str(out), "--duration-s", "1", "--no-progress", *args],
            cwd=REPO_ROOT, env=env, capture_output=True, text=True, timeout=300,
        )  # fmt: skip
        lines = process.stderr.strip().splitlines()
        assert process.returncode == 2, (args, process.stderr)
        assert len(lines) == 1 and message in lines[0], (args, lines, time.perf_counter() - start)
        # the previous run's summary kept, beside the (empty) lock file of the folder
        assert sorted(path.name for path in out.iterdir()) == ["oilwatch.lock", "summary.json"], args
        assert (out / "summary.json").read_text() == "{}\n"
