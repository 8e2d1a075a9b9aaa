"""Outputs under concurrency, full disks and interrupts, end to end through the ``oilwatch`` command (slow;
the fast checks of the same mechanisms are in test_outputs.py): two builds, two estimates and two runs
into one folder at once; estimate, run and build-fmus on a small full tmpfs; SIGINT and SIGTERM at random
moments (estimate, run); a resumed estimate against an uninterrupted one. Each checks that no torn or
mixed file remains and that the message is one line."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import zipfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from fixtures.fmu_subprocess import REPO_ROOT
from fixtures.plant_records import plant_run

from oilwatch.records.writers import write_record

pytestmark = pytest.mark.slow

ENV = dict(os.environ, OPENBLAS_NUM_THREADS="1", NUMBA_NUM_THREADS="1", PYTHONPATH=str(REPO_ROOT))
PROBES = ("x1", "y1", "x2", "y2")
RECORD_S = 30.0
"""Long enough that the estimation loop (three blocks of rows) outlasts the start-up."""
FULL_DISK_RECORD_S = 90.0
"""Long enough that estimates.csv (6.5 MB) fills the tmpfs."""
TMPFS_SIZE = "3m"


def _command(*args: str) -> list[str]:
    return [sys.executable, "-m", "oilwatch", *args]


def _start(*args: str) -> subprocess.Popen:
    return subprocess.Popen(
        _command(*args), cwd=REPO_ROOT, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def _estimate_args(record: Path, out: Path) -> list[str]:
    return ["estimate", str(record), "--out", str(out), "--no-progress", "--no-views"]


def _one_line(stderr: str) -> str:
    lines = [line for line in stderr.strip().splitlines() if line.strip()]
    assert len(lines) == 1, lines
    return lines[0]


def _whole_rows(path: Path) -> int:
    """The number of data rows of a CSV that must hold whole rows only (every line as wide as the header,
    the file ending on a newline); fails on a torn or mixed file."""
    data = path.read_bytes()
    if not data:
        return 0
    assert data.endswith(b"\n"), f"{path} ends mid-row"
    lines = data.decode().splitlines()
    width = len(lines[0].split(","))
    assert all(len(line.split(",")) == width for line in lines[1:]), f"{path} has a torn row"
    times = np.array([float(line.split(",", 1)[0]) for line in lines[1:]])
    assert np.all(np.diff(times) > 0), f"{path} mixes two runs (time goes back)"
    return len(lines) - 1


def _whole_fmus(folder: Path) -> list[str]:
    """The FMUs and SSPs under their final names, each checked whole (zip intact, pythonfmu's library
    inside the loader, not the loader twice)."""
    names = []
    for path in sorted(folder.glob("*.fmu")) + sorted(folder.glob("*.ssp")):
        with zipfile.ZipFile(path) as archive:
            assert archive.testzip() is None, path
            if path.suffix == ".fmu":
                outer = archive.read(f"binaries/linux64/{path.stem}.so")
                inner = archive.read("binaries/linux64/pythonfmu_export.so")
                assert inner != outer, f"{path}: pythonfmu_export.so is the loader"
        names.append(path.name)
    assert not [p.name for p in folder.glob(".*.partial")], "a private build folder was left behind"
    return names


@pytest.fixture(scope="module")
def steady(tmp_path_factory):
    """A 5 s plant run's steady last 4 s (300 periods at 75 Hz, so that repeats join smoothly), 1 um noise."""
    _, _, measured, _ = plant_run(5.0, 1e-3, 1.0)
    return measured[1000:]


def _steady_record(steady: np.ndarray, seconds: float, path: Path) -> Path:
    tiled = np.tile(steady, (int(seconds / 4.0), 1))
    t = 1e-3 * np.arange(1, tiled.shape[0] + 1)
    return write_record(path, {"time_s": t, **{f"{n}_um": tiled[:, i] * 1e6 for i, n in enumerate(PROBES)}})


@pytest.fixture(scope="module")
def record(steady, tmp_path_factory):
    """A :data:`RECORD_S` record of the steady motion repeated."""
    return _steady_record(steady, RECORD_S, tmp_path_factory.mktemp("records") / "steady.csv")


@pytest.fixture(scope="module")
def long_record(steady, tmp_path_factory):
    """A :data:`FULL_DISK_RECORD_S` record of the steady motion repeated."""
    return _steady_record(steady, FULL_DISK_RECORD_S, tmp_path_factory.mktemp("records") / "long.csv")


@pytest.fixture(scope="module")
def reference(record, tmp_path_factory):
    """estimates.csv of an uninterrupted run of the record, and that run's wall time [s] (the span in which
    a signal lands while the command runs, on this machine)."""
    out = tmp_path_factory.mktemp("reference")
    started = time.perf_counter()
    process = subprocess.run(
        _command(*_estimate_args(record, out)), cwd=REPO_ROOT, env=ENV, capture_output=True, text=True
    )
    wall_s = time.perf_counter() - started
    assert process.returncode == 0, process.stderr
    assert json.loads((out / "summary.json").read_text())["completed"] is True
    return (out / "estimates.csv").read_bytes(), wall_s


# ------------------------------------------------------------------ signals at random moments, resume
@pytest.mark.parametrize("seed", [0, 1])  # SIGINT, SIGTERM
def test_a_signal_at_a_random_moment_leaves_whole_rows_and_the_same_command_resumes_bit_identically(
    seed, record, reference, tmp_path
):
    reference, wall_s = reference
    rng = np.random.default_rng(seed)
    signum = (signal.SIGINT, signal.SIGTERM)[seed % 2]
    delay = float(rng.uniform(0.2, 0.95 * wall_s))  # from the imports to late in the estimation loop
    out = tmp_path / "out"
    process = _start(*_estimate_args(record, out))
    time.sleep(delay)
    process.send_signal(signum)
    _, stderr = process.communicate(timeout=300)
    if process.returncode != 0:  # 0: it finished before the signal
        assert process.returncode == 128 + signum, (delay, stderr)
        line = _one_line(stderr)
        assert f"interrupted ({signal.Signals(signum).name})" in line, line
    csv_path = out / "estimates.csv"
    kept = 0
    if csv_path.exists():
        kept = _whole_rows(csv_path)
        assert reference.startswith(csv_path.read_bytes()) or kept == 0  # the rows kept are the run's rows
        summary = json.loads((out / "summary.json").read_text())
        assert summary["completed"] is (process.returncode == 0)
        if process.returncode != 0 and kept > 0:  # stopped after a whole block: always at a resume point
            assert summary["resumable"] is True, summary
    resumed = subprocess.run(
        _command(*_estimate_args(record, out)), cwd=REPO_ROOT, env=ENV, capture_output=True, text=True
    )
    assert resumed.returncode == 0, resumed.stderr
    assert csv_path.read_bytes() == reference
    final = json.loads((out / "summary.json").read_text())
    assert final["completed"] is True
    if process.returncode != 0 and kept > 0:
        assert final["resumed_from_time_s"] > 0.0  # resumed, not started over


def test_resume_continues_from_the_saved_state_with_the_estimates_of_an_uninterrupted_run(
    record, reference, tmp_path
):
    reference, _ = reference
    out = tmp_path / "out"
    process = _start(*_estimate_args(record, out))
    deadline = time.monotonic() + 300
    csv_path = out / "estimates.csv"
    while time.monotonic() < deadline and process.poll() is None:
        if csv_path.exists() and csv_path.stat().st_size > len(reference) // 2:  # well into the record
            break
        time.sleep(0.05)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 143, stderr
    assert "the same command resumes" in _one_line(stderr)
    stopped = json.loads((out / "summary.json").read_text())
    assert stopped["completed"] is False and stopped["resumable"] is True
    assert len(csv_path.read_bytes()) < len(reference)
    process = subprocess.run(
        _command(*_estimate_args(record, out), "--resume", "yes"),
        cwd=REPO_ROOT, env=ENV, capture_output=True, text=True,
    )  # fmt: skip
    assert process.returncode == 0, process.stderr
    summary = json.loads((out / "summary.json").read_text())
    # from the point saved at the stop: the sample after the last row kept (the record starts at 1 ms)
    assert summary["resumed_from_time_s"] == pytest.approx((stopped["rows"] + 1) * 1e-3)
    assert stopped["rows"] >= 8192
    assert csv_path.read_bytes() == reference
    assert not (out / "resume_state.pickle").exists()


RUN_S = 300.0


@pytest.mark.parametrize("seed", [0, 1])
def test_a_run_stopped_at_a_random_moment_keeps_whole_rows_and_says_so_in_one_line(
    seed, built_fmus, tmp_path
):
    rng = np.random.default_rng(seed)
    signum = (signal.SIGTERM, signal.SIGINT)[seed % 2]
    delay = float(rng.uniform(0.2, 12.0))  # from the imports to the FMUs' steps
    out = tmp_path / "out"
    # 300 s of steps (a minute of wall time at the master's real-time factor of about 5): the signal, at
    # most 12 s in, lands in the step loop, not after the last row while the summary and plot are written
    process = _start("run", "constant", "--fmu-dir", str(built_fmus), "--out", str(out), "--duration-s",
                     str(RUN_S), "--no-progress")  # fmt: skip
    time.sleep(delay)
    process.send_signal(signum)
    _, stderr = process.communicate(timeout=300)
    if process.returncode == 0:
        return  # finished before the signal: nothing to check beyond the other tests
    assert process.returncode == 128 + signum, (delay, stderr)
    assert f"interrupted ({signal.Signals(signum).name})" in _one_line(stderr)
    if (out / "result.csv").exists():
        assert _whole_rows(out / "result.csv") < round(RUN_S / 1e-3) + 1
        assert json.loads((out / "summary.json").read_text())["completed"] is False


# ------------------------------------------------------------------ two writers into one folder
def _two_at_once(args_a: list[str], args_b: list[str]) -> list[subprocess.CompletedProcess]:
    processes = [_start(*args_a), _start(*args_b)]
    results = []
    for process in processes:
        stdout, stderr = process.communicate(timeout=900)
        results.append(subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr))
    return results


def _one_refused(results: list[subprocess.CompletedProcess]) -> subprocess.CompletedProcess:
    codes = sorted(result.returncode for result in results)
    assert codes == [0, 2], [(r.returncode, r.stderr[-500:]) for r in results]
    refused = next(result for result in results if result.returncode == 2)
    line = _one_line(refused.stderr)
    assert "is writing this folder" in line and "(pid " in line and ", started " in line, line
    return next(result for result in results if result.returncode == 0)


def test_two_estimates_into_one_folder_at_once_one_is_refused_and_nothing_is_mixed(
    record, reference, tmp_path
):
    out = tmp_path / "out"
    _one_refused(_two_at_once(_estimate_args(record, out), _estimate_args(record, out)))
    assert (out / "estimates.csv").read_bytes() == reference[0]
    assert json.loads((out / "summary.json").read_text())["completed"] is True


def test_two_runs_into_one_folder_at_once_one_is_refused_and_nothing_is_mixed(built_fmus, tmp_path):
    out = tmp_path / "out"
    args = ["run", "constant", "--fmu-dir", str(built_fmus), "--out", str(out), "--duration-s", "3",
            "--no-progress"]  # fmt: skip
    _one_refused(_two_at_once(args, args))
    assert _whole_rows(out / "result.csv") == 3001  # t = 0 and every 1 ms step to 3 s
    assert json.loads((out / "summary.json").read_text())["completed"] is True


def test_two_builds_into_one_folder_at_once_and_two_into_two_folders_leave_whole_fmus(tmp_path):
    same = tmp_path / "same"
    args = ["build-fmus", "--out", str(same), "--no-progress"]
    _one_refused(_two_at_once(args, args))
    assert _whole_fmus(same) == ["OilFlowEKF.fmu", "RotorBearingPlant.fmu", "OilStarvation.ssp"]
    results = _two_at_once(
        ["build-fmus", "--out", str(tmp_path / "a"), "--no-progress"],
        ["build-fmus", "--out", str(tmp_path / "b"), "--no-progress"],
    )
    assert [r.returncode for r in results] == [0, 0], [r.stderr for r in results]
    for folder in ("a", "b"):
        assert len(_whole_fmus(tmp_path / folder)) == 3


# ------------------------------------------------------------------ a full disk
@contextmanager
def _small_tmpfs(folder: Path):
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root (the EFBIG equivalent runs in test_outputs.py)")
    folder.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={TMPFS_SIZE}", "tmpfs", str(folder)],
                             capture_output=True, text=True)  # fmt: skip
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {mounted.stderr.strip()}")
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=False)


def test_estimate_run_and_build_on_a_full_disk_say_one_line_and_keep_only_whole_files(
    long_record, built_fmus, tmp_path
):
    with _small_tmpfs(tmp_path / "disk") as disk:
        out = disk / "estimate"
        process = subprocess.run(
            _command(*_estimate_args(long_record, out)), cwd=REPO_ROOT, env=ENV, capture_output=True,
            text=True,
        )  # fmt: skip
        assert process.returncode == 2, process.stderr
        line = _one_line(process.stderr)
        assert "the disk is full (ENOSPC)" in line and str(out / "estimates.csv") in line, line
        assert _whole_rows(out / "estimates.csv") > 0
        assert json.loads((out / "summary.json").read_text())["completed"] is False
        for path in out.iterdir():
            path.unlink()

        out = disk / "run"
        process = subprocess.run(
            _command("run", "constant", "--fmu-dir", str(built_fmus), "--out", str(out), "--duration-s", "20",
                     "--no-progress"),
            cwd=REPO_ROOT, env=ENV, capture_output=True, text=True,
        )  # fmt: skip
        assert process.returncode == 2, process.stderr
        line = _one_line(process.stderr)
        assert "ENOSPC" in line and str(out / "result.csv") in line, line
        assert 0 < _whole_rows(out / "result.csv") < 20000
        assert json.loads((out / "summary.json").read_text())["completed"] is False
        for path in out.iterdir():
            path.unlink()

        out = disk / "fmus"
        process = subprocess.run(
            _command("build-fmus", "--out", str(out), "--no-progress"), cwd=REPO_ROOT, env=ENV,
            capture_output=True, text=True,
        )  # fmt: skip
        assert process.returncode == 2, process.stderr
        assert "ENOSPC" in _one_line(process.stderr)
        assert len(_whole_fmus(out)) < 3  # what is there is whole; the rest is not there at all
