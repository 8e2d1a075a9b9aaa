"""``oilwatch estimate`` (issue 15): a plant run written out as CSV, Parquet and TDMS gives the estimates of
the co-simulated estimator on the same data; standard input gives the file's estimates; report.html is
self-contained; several records run as Dask tasks."""

from __future__ import annotations

import base64
import json
import os
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from fixtures.fmu_subprocess import REPO_ROOT, run_json
from fixtures.plant_records import REST_GAP_V, gap_voltages, keyphasor, plant_run, read_estimates

from oilwatch.cli import main
from oilwatch.cli.estimate import output_folder_name
from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import ML_MIN
from oilwatch.estimator.measurement import probe_rotation
from oilwatch.monitoring.estimate import estimator_config, estimator_model
from oilwatch.records.writers import write_record

NOMINAL = 596.3
TOLERANCE_ML_MIN = 0.001 * NOMINAL  # 0.1 % of nominal
PROBES = ("x1", "y1", "x2", "y2")


def _onsets(flags: np.ndarray, times: np.ndarray) -> np.ndarray:
    flags = np.asarray(flags) > 0.5
    return times[np.flatnonzero(flags & ~np.concatenate([[False], flags[:-1]]))]


def _estimate(record: Path, out: Path, *extra: str) -> dict:
    """``oilwatch estimate`` on the paper preset, the configuration of the references these tests compare
    with (the scenarios' estimator FMU, the nuisances known)."""
    preset = [] if "--preset" in extra else ["--preset", "paper"]
    assert main(["estimate", str(record), "--out", str(out), "--no-progress", *preset, *extra]) == 0
    return json.loads((out / "summary.json").read_text())


@pytest.fixture(scope="module")
def drop_record(tmp_path_factory):
    """A 3 s plant run at 1 kHz (bearing 1 drops to 75 % at 1.5 s), 1 um noise, as a CSV record in um."""
    t, _, measured, _ = plant_run(3.0, 1e-3, 1.0, drop_at_s=1.5)
    path = tmp_path_factory.mktemp("records") / "drop.csv"
    columns = {"time_s": t, **{f"{n}_um": measured[:, i] * 1e6 for i, n in enumerate(PROBES)}}
    return write_record(path, columns)


def test_csv_and_parquet_of_a_cosimulated_run_give_the_fmu_estimates_and_alarms(built_fmus, tmp_path):
    cosim = run_json(
        f"""
from pathlib import Path
from oilwatch.cosim import Master
from oilwatch.scenarios import make_run
from oilwatch.scenarios.fmus import plant_and_estimator
run = make_run("drop-b1", duration_s=3.0)
record = ["plant.t_sample_s"] + [f"plant.{{n}}_um" for n in ("x1", "y1", "x2", "y2")] + [
    f"ekf.{{n}}" for n in ("q1_est_ml_min", "q2_est_ml_min", "q1_std_ml_min", "q2_std_ml_min", "starved1",
                          "starved2")]
with Master(plant_and_estimator(Path({str(built_fmus)!r}))) as master:
    out = master.run(stop_time=3.0, step_size=1e-3, start_time=0.0, order=["plant", "ekf"], record=record,
                     parameters={{"plant": run.plant_parameters(), "ekf": run.ekf_parameters()}})
arrays = out.recorder.arrays()
result = {{name: arrays[name][1:].tolist() for name in record}}  # the rows after each step
""",
        timeout=400,
    )
    t = np.array(cosim["plant.t_sample_s"])
    columns = {"time_s": t, **{f"{n}_um": np.array(cosim[f"plant.{n}_um"]) for n in PROBES}}
    fmu_alarm = _onsets(cosim["ekf.starved1"], t)
    assert fmu_alarm.size == 1 and not any(cosim["ekf.starved2"])  # the case is worth comparing
    for suffix in ("csv", "parquet"):
        out = tmp_path / suffix
        record = write_record(tmp_path / f"run.{suffix}", columns)
        summary = _estimate(record, out, "--no-views", "--offset-prior-um", "0")  # the FMU's default
        ours = read_estimates(out)
        np.testing.assert_allclose(ours["time_s"], t, atol=1e-9)
        for b in (1, 2):
            error = np.abs(ours[f"q{b}_est_ml_min"] - np.array(cosim[f"ekf.q{b}_est_ml_min"]))
            assert error.max() < TOLERANCE_ML_MIN, (suffix, b, error.max())
            std_error = np.abs(ours[f"q{b}_std_ml_min"] - np.array(cosim[f"ekf.q{b}_std_ml_min"]))
            assert std_error.max() < TOLERANCE_ML_MIN
        alarms = [a for a in summary["alarms"] if a["bearing"] == 1]
        assert len(summary["alarms"]) == 1 and abs(alarms[0]["time_s"] - fmu_alarm[0]) <= 0.010
        final = t > 2.7  # the last 10 % of the record
        assert summary["final_window_s"] == pytest.approx(0.3)
        assert summary["q1_final_ml_min"] == pytest.approx(
            np.mean(cosim["ekf.q1_est_ml_min"][-300:]), abs=0.01
        )
        assert summary["q2_std_final_ml_min"] == pytest.approx(
            np.mean(np.array(cosim["ekf.q2_std_ml_min"])[final]), abs=0.01
        )
        assert summary["record"]["format"] == suffix and summary["record"]["rows"] == 3000


@pytest.mark.slow
def test_tdms_gap_voltages_api670_offsets_keyphasor_at_5khz_give_the_estimator_s_flowrates(tmp_path):
    """The TDMS record: API 670 probes (45 deg either side of top dead centre), gap voltages at 7.87 V/mm,
    each probe its own rest gap (the offsets, corrected by rest_gap_v and declared known with
    --offset-prior-um 0; unknown offsets against the FMU: tests/test_estimate_cosim_nuisances.py), a notch
    keyphasor at rotor angle 40 deg, a DAQ clock 0.3712 s off the rotor's angle zero, 5 kHz. Reference: the
    estimator fed the same run's samples at 1 kHz along the probes' axes, offset-corrected.
    """
    t, _, measured, _ = plant_run(2.0, 2e-4, 0.3, drop_at_s=-10.0)  # bearing 1 at 75 % throughout
    shift = 0.3712
    channels = {"time_s": t + shift, **gap_voltages(measured), "kp": keyphasor(t, angle_deg=40.0)}
    record = write_record(tmp_path / "rig.tdms", channels, units={name: "V" for name in channels})
    probe = ["layout=api670", "keyphasor_column=kp", "keyphasor_angle_deg=40", "noise_um=0.3"]
    for n in PROBES:
        probe += [f"{n}.column={n}_gap", f"{n}.unit=V", f"{n}.rest_gap_v={REST_GAP_V[n]}"]
    probe_options = [f"--probe={p}" for p in probe]
    summary = _estimate(
        record,
        tmp_path / "out",
        "--no-views",
        "--offset-prior-um",
        "0",
        "--operating-point",
        "nominal",
        *probe_options,
    )  # fmt: skip  (the reference: the estimator at the nominal point; the keyphasor speed is not followed)
    ours = read_estimates(tmp_path / "out")
    assert summary["record"]["anti_alias_taps"] > 1 and summary["record"]["keyphasor_pulses"] == 150
    np.testing.assert_allclose(ours["speed_hz"][-100:], 75.0, rtol=2e-4)

    # the estimator FMU's way with API 670 probes: the readings along their axes, probe_angle_deg = 45
    # --preset paper: no mismatch action
    paper = estimator_config(75.0, 0.3, 0.0, probe_angle_deg=45.0, model_mismatch_action=False)
    reference = OilFlowEKF(estimator_model(None), paper)
    reference.step(np.full(4, np.nan))  # as the FMU started at t = 0
    trace = reference.run(measured[4::5] @ probe_rotation(np.radians(45.0)).T)
    ref_t, ref_q = t[4::5], trace.q_m3_s / ML_MIN
    plant_time = ours["time_s"] - shift
    window = summary["final_window_s"]
    for b in (1, 2):
        ref_final = ref_q[ref_t > ref_t[-1] - window, b - 1].mean()
        assert abs(summary[f"q{b}_final_ml_min"] - ref_final) < TOLERANCE_ML_MIN, (b, summary, ref_final)
        converged = plant_time > 1.0
        gap = np.abs(
            ours[f"q{b}_est_ml_min"][converged] - np.interp(plant_time[converged], ref_t, ref_q[:, b - 1])
        )
        assert gap.max() < 3 * TOLERANCE_ML_MIN
    ref_alarm = _onsets(trace.starved[:, 0], ref_t)
    ours_alarm = [a["time_s"] - shift for a in summary["alarms"] if a["bearing"] == 1]
    assert len(ref_alarm) == len(ours_alarm) == 1 and abs(ours_alarm[0] - ref_alarm[0]) <= 0.010
    assert not any(a["bearing"] == 2 for a in summary["alarms"]) and not trace.starved[:, 1].any()


PAPER_LIVE = ("--no-views", "--preset", "paper")


@pytest.mark.slow
def test_standard_input_gives_the_file_mode_estimates_line_by_line(drop_record, tmp_path):
    _estimate(drop_record, tmp_path / "file", "--no-views")
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(REPO_ROOT))
    process = subprocess.run(
        [sys.executable, "-m", "oilwatch", "estimate", "-", "--out", str(tmp_path / "live"), *PAPER_LIVE],
        input=drop_record.read_text(),
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        cwd=REPO_ROOT,
    )
    assert process.returncode == 0, process.stderr
    assert process.stdout == (tmp_path / "file" / "estimates.csv").read_text()
    assert process.stdout == (tmp_path / "live" / "estimates.csv").read_text()
    summary = json.loads((tmp_path / "live" / "summary.json").read_text())
    assert summary["record"]["source"] == "stdin" and summary["live_latency_ms"]["median"] > 0


class _Resources(HTMLParser):
    """Every URL-bearing attribute and tag of a page."""

    def __init__(self):
        super().__init__()
        self.urls, self.tags, self.images = [], [], []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        for name, value in attrs:
            if name in ("src", "href", "srcset", "data", "poster", "action"):
                self.urls.append(value)
            if tag == "img" and name == "src":
                self.images.append(value)


@pytest.mark.slow
def test_report_html_is_self_contained_with_the_verdicts_and_four_views(drop_record, tmp_path):
    summary = _estimate(drop_record, tmp_path / "out")
    page = (tmp_path / "out" / "report.html").read_text()
    parser = _Resources()
    parser.feed(page)
    assert len(parser.images) == 4
    assert all(url.startswith("data:image/png;base64,") for url in parser.urls), parser.urls
    for image in parser.images:
        assert base64.b64decode(image.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"
    assert not {"script", "link", "iframe", "object", "embed"} & set(parser.tags)
    assert "url(" not in page and "@import" not in page and "http" not in page
    assert "bearing 1" in page and summary["verdict"]["bearing1"].split(":")[0] in page
    assert summary["verdict"]["bearing1"].startswith("STARVED")
    assert summary["verdict"]["bearing2"].startswith("healthy")
    assert set(summary["views"]) == {"trend", "centerline", "orbits", "probe_health"}
    assert {"bearing", "time_s", "consistent"} <= set(summary["alarms"][0])
    assert summary["q1_final_ml_min"] == pytest.approx(0.75 * NOMINAL, rel=0.02)


@pytest.mark.slow
def test_several_records_run_as_dask_tasks_one_folder_each(drop_record, tmp_path):
    second = tmp_path / "second.csv"
    second.write_text(drop_record.read_text())
    out = tmp_path / "many"
    code = main(["estimate", str(drop_record), str(second), "--out", str(out), "--workers", "1",
                 "--preset", "paper", "--no-views", "--no-progress"])  # fmt: skip
    assert code == 0
    folders = {
        name: out / output_folder_name(str(path))
        for name, path in (("drop", drop_record), ("second", second))
    }
    first = json.loads((folders["drop"] / "summary.json").read_text())
    other = json.loads((folders["second"] / "summary.json").read_text())
    assert first["q1_final_ml_min"] == other["q1_final_ml_min"]
    assert (folders["drop"] / "estimates.csv").read_text() == (
        folders["second"] / "estimates.csv"
    ).read_text()
