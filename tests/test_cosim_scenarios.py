"""The paper's real-time scenarios (issue 7): definitions, figures of merit, every scenario through the two
FMUs (shortened runs), the OilStarvation.ssp bindings, and libcosim (OSP) against oilwatch's fmpy master.

FMU runs happen in fresh subprocesses (pythonfmu FMUs share the host interpreter). The FMUs are built
once per session (``built_fmus`` in conftest.py); the extraction cache lives in a per-session folder, so
the estimator's numba kernels compile once per session.
"""

from __future__ import annotations

import os
import time

import numpy as np
import pytest
from fixtures.fmu_subprocess import run_json
from fixtures.xdist_units import session_root

from oilwatch.cli.run import SCENARIO_NAMES
from oilwatch.models.system.fault import SCENARIO_DURATIONS_S, SigmoidFlowrate
from oilwatch.models.validation import InputError
from oilwatch.scenarios import SCENARIOS, make_run
from oilwatch.scenarios.summary import first_alarm_s, settle_time_s, summarize, window_error_pct

NOMINAL_ML_MIN = 596.3  # the bundled turbine's nominal flowrate (its machine file; reference value)


@pytest.fixture(autouse=True)
def session_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("OILWATCH_CACHE", str(session_root(tmp_path_factory) / "oilwatch_cache"))


# ----------------------------------------------------------------------------------------- definitions
def test_scenario_flowrates_are_the_papers_percentages_and_the_sigmoid_is_centred():
    assert SCENARIO_NAMES == tuple(SCENARIOS)
    drop, flood = 0.75 * NOMINAL_ML_MIN, 1.25 * NOMINAL_ML_MIN
    expected = {
        "constant": ((596.3, 596.3), (596.3, 596.3)),
        "slow-drop": ((596.3, drop), (596.3, drop)),
        "intermediate-drop": ((596.3, drop), (596.3, drop)),
        "sudden-drop": ((596.3, drop), (596.3, drop)),
        "drop-b1": ((596.3, drop), (596.3, 596.3)),
        "drop-b2": ((596.3, 596.3), (596.3, drop)),
        "clog-b1": ((596.3, drop), (596.3, flood)),
        "clog-b2": ((596.3, flood), (596.3, drop)),
    }
    for name, (q1, q2) in expected.items():
        run = make_run(name, duration_s=20.0)
        np.testing.assert_allclose(run.q1_ml_min, q1, atol=1e-6)
        np.testing.assert_allclose(run.q2_ml_min, q2, atol=1e-6)
        assert run.fault_time_s == 10.0
    assert round(flood, 1) == 745.4  # the paper's clogged-line rise
    assert make_run("slow-drop").fault_duration_s == SCENARIO_DURATIONS_S["slow"] == 4.0
    assert make_run("sudden-drop").fault_duration_s == 0.1
    assert make_run("drop-b1").fault_duration_s == make_run("clog-b2").fault_duration_s == 1.0
    assert make_run("sudden-drop", duration_s=6.0).fault_time_s == 3.0
    constant = make_run("constant", q1_pct=80.0, q2_pct=90.0)
    assert constant.q1_ml_min == (477.04, 477.04) and constant.q2_ml_min == (536.67, 536.67)
    assert [constant.starving(1), constant.starving(2)] == [True, False]
    assert make_run("clog-b1").starving(1) and not make_run("clog-b1").starving(2)


@pytest.mark.parametrize(
    "kwargs, names",
    [
        ({"name": "sudden"}, "sudden-drop"),
        ({"name": "constant", "noise_um": -1.0}, "--noise-um"),
        ({"name": "constant", "duration_s": 0.5}, "--duration-s"),
        ({"name": "constant", "duration_s": 5.0005}, "--duration-s"),
        ({"name": "constant", "seed": -3}, "--seed"),
        ({"name": "constant", "q1_pct": 0.0}, "--q1-pct"),
        ({"name": "drop-b1", "q2_pct": 80.0}, "--q1-pct and --q2-pct"),
    ],
)
def test_bad_scenario_settings_name_the_input(kwargs, names):
    with pytest.raises(InputError, match=names.replace("-", r"\-")):
        make_run(**kwargs)


def test_error_windows_and_alarm_delay_follow_their_definitions():
    run = make_run("sudden-drop", duration_s=20.0)  # centre 10 s, transition starts at 9.9 s
    time_s = np.round(np.arange(20001) * 1e-3, 9)
    true = np.where(time_s < 10.0, 596.3, 447.225)
    estimate = true * np.where(time_s < 7.9, 1.5, np.where(time_s < 9.9, 1.04, 1.01))
    estimate[time_s >= 18.0] = 447.225 * 0.99
    starved = ((time_s >= 10.6) | ((time_s >= 3.0) & (time_s < 3.5))).astype(float)
    columns = {"time_s": time_s, "starved1": starved, "starved2": np.zeros_like(time_s)}
    for b in (1, 2):
        columns[f"q{b}_true_ml_min"], columns[f"q{b}_est_ml_min"] = true, estimate
    summary = summarize(run, columns)
    assert summary["q1_err_pct_before"] == pytest.approx(4.0)  # [7.9, 9.9) only
    assert summary["q1_err_pct_after"] == pytest.approx(1.0)  # [18, 20]
    assert summary["alarm_delay_s_b1"] == pytest.approx(0.6)
    assert summary["false_alarm_s_b1"] == pytest.approx(3.0)
    assert summary["alarm_delay_s_b2"] is None and summary["false_alarm_s_b2"] is None
    assert summary["first_alarm_s_b1"] == pytest.approx(3.0) and summary["first_alarm_s_b2"] is None
    assert summary["q1_settle_s"] == 0.0  # within 2 % from the centre on
    # A bearing starved from the start: its alarm is a detection, neither false nor a delay.
    starved_run = make_run("constant", q1_pct=80.0, duration_s=20.0)
    detected = summarize(starved_run, {**columns, "starved1": (time_s >= 0.3).astype(float)})
    assert detected["starved_initially_b1"] and not detected["starved_initially_b2"]
    assert detected["first_alarm_s_b1"] == pytest.approx(0.3)
    assert detected["false_alarm_s_b1"] is None and detected["alarm_delay_s_b1"] is None
    slow = estimate.copy()
    slow[(time_s >= 10.0) & (time_s < 12.5)] *= 1.05
    assert settle_time_s(time_s, true, slow, 10.0) == pytest.approx(2.5)
    slow[-1] *= 1.05
    assert settle_time_s(time_s, true, slow, 10.0) is None
    # A window that starts before the record has no value (a short slow drop).
    assert window_error_pct(time_s, true, estimate, -1.0, 1.0) is None
    assert first_alarm_s(time_s, np.zeros_like(time_s), 0.0) is None


# ------------------------------------------------------------------------------------ through the FMUs
def test_every_scenario_runs_through_both_fmus_in_a_shortened_record(built_fmus, tmp_path):
    duration = 5.0
    result = run_json(
        f"""
import json, math
from pathlib import Path
from oilwatch.scenarios import SCENARIOS, make_run
from oilwatch.scenarios.runner import run_scenario, read_result
result = {{}}
for name in SCENARIOS:
    out = Path({str(tmp_path)!r}) / name
    summary = run_scenario(make_run(name, duration_s={duration}), out, fmu_dir=Path({str(built_fmus)!r}),
                           progress=False, plot=(name == "clog-b1"))
    columns = read_result(out / "result.csv")
    result[name] = {{
        "summary": summary,
        "rows": len(columns["time_s"]),
        "end": columns["time_s"][-1],
        "true_end": [columns["q1_true_ml_min"][-1], columns["q2_true_ml_min"][-1]],
        "est_end": [columns["q1_est_ml_min"][-1], columns["q2_est_ml_min"][-1]],
        "finite": all(math.isfinite(v) for c in columns.values() for v in c),
        "png": (out / "estimates.png").is_file(),
        "saved": json.loads((out / "summary.json").read_text())["scenario"],
    }}
""",
        timeout=400,
    )
    assert result["clog-b1"]["png"]
    for name, got in result.items():
        run = make_run(name, duration_s=duration)
        summary = got["summary"]
        assert got["rows"] == 5001 and got["end"] == pytest.approx(duration) and got["finite"], name
        assert got["saved"] == name
        for b, (initial, final) in enumerate((run.q1_ml_min, run.q2_ml_min)):
            sigmoid = SigmoidFlowrate(initial, final, run.fault_time_s, run.fault_duration_s)
            assert got["true_end"][b] == pytest.approx(sigmoid(duration), rel=1e-9), (name, b)
            # The estimate follows the truth to within the flooded bearing's poor sensitivity (paper
            # 9-14 % at 125 %); every other bearing well within 5 %.
            limit = 0.15 if final > NOMINAL_ML_MIN else 0.05
            assert abs(got["est_end"][b] - got["true_end"][b]) < limit * got["true_end"][b], (name, b)
            delay = summary[f"alarm_delay_s_b{b + 1}"]
            if run.starving(b + 1) and name != "slow-drop":
                # Slow drop: 2.5 s after the centre the flow is only at 94 % of its change.
                assert delay is not None and 0.0 < delay < 2.0, (name, b, delay)
            elif not run.starving(b + 1):
                assert delay is None, (name, b, delay)
            assert summary[f"false_alarm_s_b{b + 1}"] is None, (name, b)
        before_window_fits = run.transition_start_s >= 2.0
        assert (summary["q1_err_pct_before"] is None) == (not before_window_fits), name


def test_ssp_binds_the_sudden_drop_and_connects_the_sample_time(built_fmus):
    result = run_json(
        f"""
from oilwatch.cosim.ssp import open_ssp
with open_ssp({str(built_fmus / "OilStarvation.ssp")!r}) as system:
    result = {{
        "parameters": {{spec.name: spec.parameters for spec in system.fmus}},
        "connections": sorted(str(c) for c in system.connections),
        "experiment": [system.stop_time, system.step_size],
    }}
"""
    )
    run = make_run("sudden-drop")
    for instance, expected in (("plant", run.plant_parameters()), ("ekf", run.ekf_parameters())):
        bound = result["parameters"][instance]
        for name, value in expected.items():
            assert bound[name] == pytest.approx(value), (instance, name)
    connected = {c.split(" -> ")[1] for c in result["connections"]}
    # the keyphasor (rotor angle) is wired by name, as an FMI host with a keyphasor channel would
    expected_inputs = ("x1_um", "y1_um", "x2_um", "y2_um", "t_sample_s", "rotor_angle_deg")
    assert connected == {f"ekf.{n}" for n in expected_inputs}
    assert result["experiment"] == [20.0, 1e-3]


def test_libcosim_runs_the_same_ssp_and_agrees_with_the_fmpy_master(built_fmus, tmp_path):
    """libcosim's fixed-step algorithm is Jacobi: the estimator sees the plant's sample of time t during
    the step t -> t + h, one step later than under oilwatch's Gauss-Seidel order. The plant FMU's
    t_sample_s keeps the filter on its time grid, so libcosim's estimate at t + h must equal fmpy's at t.
    Only the start differs: libcosim's filter also uses the sample of t = 0, which Gauss-Seidel never
    passes, and that difference decays as the filter forgets its start. Tolerances (measured on the
    synchronous-coefficient default, largest shifted difference per half second: 0.96 ml/min in 0.5-1 s,
    0.26 in 1-1.5 s, 0.028 in 1.5-2 s, 4e-4 in 3-3.5 s, 1e-9 after 3.5 s): with the one-step shift,
    0.1 ml/min (0.02 % of nominal) from 1.5 s on and 0.005 ml/min from 4 s on; without it, one step's change
    of the estimate plus 0.1 ml/min from 1.5 s on. The
    alarms come one step later in libcosim (one more step allowed for threshold crossings)."""
    duration = 6.0
    ssp = tmp_path / "SuddenDrop6s.ssp"
    result = run_json(
        f"""
import numpy as np
from oilwatch.cosim import FmuSpec, SystemDescription
from oilwatch.cosim.libcosim_runner import run_ssp_libcosim
from oilwatch.cosim.ssp import master_from_ssp, write_ssp
from oilwatch.scenarios import make_run
run = make_run("sudden-drop", duration_s={duration})
build = {str(built_fmus)!r}
write_ssp({str(ssp)!r}, SystemDescription(
    [FmuSpec("plant", build + "/RotorBearingPlant.fmu", run.plant_parameters()),
     FmuSpec("ekf", build + "/OilFlowEKF.fmu", run.ekf_parameters())],
    stop_time={duration}, step_size=1e-3, name="SuddenDrop6s"))
record = ["ekf.q1_est_ml_min", "ekf.q2_est_ml_min", "ekf.starved1", "ekf.starved2", "plant.x1_um"]
with master_from_ssp({str(ssp)!r}) as master:
    fmpy_rows = master.run(record=record).recorder.arrays()
osp = run_ssp_libcosim({str(ssp)!r}, record)
result = {{"fmpy": {{k: v.tolist() for k, v in fmpy_rows.items()}},
          "osp": {{k: v.tolist() for k, v in osp.items()}}}}
""",
        timeout=300,
    )
    fm = {k: np.array(v) for k, v in result["fmpy"].items()}  # rows t = 0, h, ..., 6 s
    osp = {k: np.array(v) for k, v in result["osp"].items()}  # rows t = h, ..., 6 s
    np.testing.assert_allclose(osp["time"], fm["time"][1:], atol=1e-9)
    np.testing.assert_array_equal(osp["plant.x1_um"], fm["plant.x1_um"][1:])  # same plant, same noise
    time_s = osp["time"]
    for b in (1, 2):
        key = f"ekf.q{b}_est_ml_min"
        shifted = np.abs(osp[key] - fm[key][:-1])
        assert shifted[time_s >= 1.5].max() < 0.1, shifted[time_s >= 1.5].max()
        assert shifted[time_s >= 4.0].max() < 0.005
        same_time = np.abs(osp[key] - fm[key][1:])
        one_step_change = np.abs(np.diff(fm[key]))
        assert np.all(same_time[time_s >= 1.5] <= one_step_change[time_s >= 1.5] + 0.1)
        assert np.abs(osp[key][-1] - 447.225) < 0.02 * 447.225  # both saw the drop
        alarm_osp = time_s[np.argmax(osp[f"ekf.starved{b}"] > 0)]
        alarm_fmpy = fm["time"][np.argmax(fm[f"ekf.starved{b}"] > 0)]
        assert osp[f"ekf.starved{b}"].any() and abs(alarm_osp - (alarm_fmpy + 1e-3)) <= 1e-3 + 1e-9


def test_fmus_are_unpacked_once_per_content_into_the_cache(built_fmus):
    """The persistent extraction folder (numba's cache stays valid there) is keyed by the instance name
    and the FMU's SHA-256 and reused by later instances; with OILWATCH_FMU_CACHE=0 each instance gets a
    temporary folder, removed on close."""
    code = f"""
import hashlib, os
from pathlib import Path
from oilwatch.cosim.loading import Slave
fmu = Path({str(built_fmus / "RotorBearingPlant.fmu")!r})
folders = []
for name in ("plant", "plant", "other"):
    slave = Slave(name, fmu)
    folders.append(str(slave.unzip_directory))
    slave.close()
os.environ["OILWATCH_FMU_CACHE"] = "0"
private = Slave("plant", fmu)
temporary = private.unzip_directory
existed = temporary.is_dir()
private.close()
result = {{"folders": folders, "kept": Path(folders[0], "modelDescription.xml").is_file(),
          "sha": hashlib.sha256(fmu.read_bytes()).hexdigest(), "temporary": str(temporary),
          "existed": existed, "removed": not temporary.exists()}}
"""
    result = run_json(code)
    first, again, other = result["folders"]
    assert first == again != other
    assert first == os.path.join(os.environ["OILWATCH_CACHE"], "fmus", "oilwatch_plant_" + result["sha"])
    assert result["kept"]
    assert result["temporary"] not in result["folders"] and result["existed"] and result["removed"]


def test_prune_keeps_the_most_recently_used_folders(tmp_path):
    from oilwatch.cosim.extraction import prune

    for age, name in enumerate(["newest", "middle", "oldest", ".partial-x"]):
        folder = tmp_path / name
        folder.mkdir()
        stamp = time.time() - 100 * age
        os.utime(folder, (stamp, stamp))
    prune(tmp_path, 2)
    names = sorted(p.name for p in tmp_path.iterdir() if p.name != ".locks")
    assert names == [".partial-x", "middle", "newest"]


def test_prune_leaves_a_folder_in_use(tmp_path):
    """Two processes sharing one cache (two test workers, two monitors): a folder whose user holds its lock
    survives pruning however old it is, and goes once released; its lock file goes with it."""
    from oilwatch.cosim import extraction

    if extraction.fcntl is None:
        pytest.skip("folder locks need fcntl (POSIX)")
    for age, name in enumerate(["newest", "middle", "oldest"]):
        folder = tmp_path / name
        folder.mkdir()
        stamp = time.time() - 100 * age
        os.utime(folder, (stamp, stamp))
    in_use = extraction.Extraction(tmp_path / "oldest", True, extraction.lock_folder(tmp_path / "oldest"))
    extraction.prune(tmp_path, 1)
    assert sorted(p.name for p in tmp_path.iterdir()) == [".locks", "newest", "oldest"]
    in_use.release()
    in_use.release()  # idempotent: the loader's close may come twice
    extraction.prune(tmp_path, 1)
    assert sorted(p.name for p in tmp_path.iterdir()) == [".locks", "newest"]
    assert list((tmp_path / ".locks").iterdir()) == []
