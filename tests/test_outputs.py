"""Outputs that are whole, one writer per folder, honest stops (oilwatch.outputs): the fast checks. The
end-to-end ones (two writers at once, a full tmpfs, signals at random moments, a resume against an
uninterrupted run) are in test_outputs_stress.py."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest
from fixtures.fmu_subprocess import REPO_ROOT

from oilwatch.cli import main
from oilwatch.models.validation import InputError
from oilwatch.outputs import interrupts
from oilwatch.outputs.atomic import atomic_path, write_json_atomic
from oilwatch.outputs.lock import LOCK_NAME, output_lock
from oilwatch.outputs.rows import OutputError, RowFile

ENV = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(REPO_ROOT))


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    path = write_json_atomic(tmp_path / "summary.json", {"run": 1})
    with pytest.raises(RuntimeError), atomic_path(path) as temporary:
        temporary.write_text("half")
        raise RuntimeError("disk gone")
    assert json.loads(path.read_text()) == {"run": 1}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["summary.json"]


def test_a_signal_waits_for_the_end_of_a_deferred_block_and_then_stops_with_its_code():
    order = []
    interrupts.reset_for_tests()  # another test of this process may have left a signal received
    with pytest.raises(interrupts.Interrupted) as stop, interrupts.held():
        os.kill(os.getpid(), signal.SIGTERM)
        order.append("after the signal, inside the block")
    assert order and stop.value.exit_code == 143 and stop.value.name == "SIGTERM"
    interrupts.reset_for_tests()


LIMITED_WRITER = """
import resource, signal, sys
from oilwatch.outputs.rows import OutputError, RowFile
# a write past the limit fails (EFBIG) part-way, as on a full disk
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (1000, 1000))
rows = RowFile(sys.argv[1])
try:
    for k in range(100):
        rows.write(f"{k},{k * 0.5!r},{'x' * 30}\\n" * 3)
except OutputError as error:
    print(error)
"""


def test_a_write_that_fails_part_way_is_cut_back_to_whole_rows(tmp_path):
    path = tmp_path / "rows.csv"
    process = subprocess.run(
        [sys.executable, "-c", LIMITED_WRITER, str(path)], env=ENV, capture_output=True, text=True
    )
    assert process.stdout.startswith(f"cannot write {path}: the file is too large (EFBIG)"), process
    data = path.read_bytes()
    assert 0 < len(data) <= 1000 and data.endswith(b"\n")
    assert all(len(line.split(",")) == 3 for line in data.decode().splitlines())


def test_row_file_on_a_device_without_room_raises_output_error():
    rows = RowFile("/dev/full")
    with pytest.raises(OutputError, match=r"cannot write /dev/full: the disk is full \(ENOSPC\)"):
        rows.write("1,2\n")
    rows.close()


def test_a_second_writer_is_refused_naming_the_holder_and_a_dead_holders_lock_is_taken_over(tmp_path):
    holder = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent("""
            import sys, time
            from oilwatch.outputs.lock import output_lock
            with output_lock(sys.argv[1], "run"):
                print("locked", flush=True)
                time.sleep(60)
        """), str(tmp_path)],
        env=ENV, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(InputError) as refused, output_lock(tmp_path, "estimate"):
            pass
        message = str(refused.value)
        assert f"oilwatch run (pid {holder.pid}, started 20" in message and "\n" not in message
    finally:
        holder.kill()
        holder.wait()
    with output_lock(tmp_path, "estimate"):
        assert json.loads((tmp_path / LOCK_NAME).read_text())["command"] == "estimate"


def test_a_writer_refused_before_the_holder_wrote_its_record_still_names_the_holder(tmp_path):
    """The holder writes its record just after taking the lock; a second writer arriving in between waits
    for it instead of naming no holder."""
    import fcntl
    import threading

    record = {"pid": 4242, "command": "run", "started": "2026-01-01T00:00:00Z"}
    with open(tmp_path / LOCK_NAME, "a+", encoding="utf-8") as holder:
        fcntl.flock(holder, fcntl.LOCK_EX | fcntl.LOCK_NB)  # locked, its record not yet written

        def write_record():
            time.sleep(0.2)
            holder.write(json.dumps(record) + "\n")
            holder.flush()

        writer = threading.Thread(target=write_record)
        writer.start()
        with pytest.raises(InputError) as refused, output_lock(tmp_path, "estimate"):
            pass
        writer.join()
    assert "oilwatch run (pid 4242, started 2026-01-01T00:00:00Z) is writing" in str(refused.value)


FINALIZER_AT_EXIT = """
import sys
import oilwatch.cli as cli

class HalfBuilt:  # as an llvmlite object a signal left mid-compilation: its finalizer fails at exit
    def __del__(self):
        raise AttributeError("no attribute '_as_parameter_'")

def main():
    cli.LEFT = HalfBuilt()
    print("oilwatch estimate: interrupted (SIGTERM); no output written", file=sys.stderr)
    return int(sys.argv[1])

cli.main = main
cli.console_main()
"""


@pytest.mark.parametrize("code", [143, 130, 0])
def test_an_interrupted_command_says_one_line_even_when_a_finalizer_fails_at_exit(code):
    process = subprocess.run(
        [sys.executable, "-c", FINALIZER_AT_EXIT, str(code)], env=ENV, capture_output=True, text=True
    )
    lines = [line for line in process.stderr.splitlines() if line.strip()]
    assert process.returncode == code
    if code:
        assert lines == ["oilwatch estimate: interrupted (SIGTERM); no output written"], lines
    else:  # a command that ends normally still reports a failing finalizer
        assert any("_as_parameter_" in line for line in lines), lines


SLOW_TEARDOWN = """
import sys, time
import oilwatch.cli as cli

class SlowTeardown:  # destroyed with the modules, after Python has handed its signals back
    def __del__(self):
        sys.__stderr__.write("tearing down\\n")
        sys.__stderr__.flush()
        time.sleep(2.0)

def main():
    cli.LEFT = SlowTeardown()
    return 0

cli.main = main
cli.console_main()
"""


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_during_the_teardown_of_a_finished_command_leaves_its_exit_code(signum):
    process = subprocess.Popen(
        [sys.executable, "-c", SLOW_TEARDOWN], env=ENV, stderr=subprocess.PIPE, text=True
    )
    assert process.stderr.readline() == "tearing down\n"
    process.send_signal(signum)
    _, stderr = process.communicate(timeout=30)
    assert process.returncode == 0, (process.returncode, stderr)  # -signum before: the default action
    assert stderr == ""


def test_estimate_into_a_locked_folder_is_one_line_and_writes_nothing(tmp_path, capsys):
    record = tmp_path / "r.csv"
    rows = "".join(f"{k / 1000},0,0,0,0\n" for k in range(1, 50))
    record.write_text("time_s,x1_um,y1_um,x2_um,y2_um\n" + rows)
    out = tmp_path / "out"
    with output_lock(out, "estimate"):
        assert main(["estimate", str(record), "--out", str(out), "--no-progress"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and f"oilwatch estimate (pid {os.getpid()}" in lines[0]
    assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME]


@pytest.mark.parametrize("out", ["/proc/oilwatch_out", "/sys/oilwatch_out"])
def test_an_output_where_no_file_can_be_made_is_one_line(out, tmp_path, capsys):
    record = tmp_path / "r.csv"
    record.write_text("time_s,x1_um,y1_um,x2_um,y2_um\n0.001,0,0,0,0\n")
    assert main(["estimate", str(record), "--out", out, "--no-progress"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and out in lines[0], lines


LIMITED_ATOMIC = """
import resource, signal, sys
from oilwatch.outputs.atomic import write_bytes_atomic
from oilwatch.outputs.rows import OutputError
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (1000, 1000))
try:
    write_bytes_atomic(sys.argv[1], b"x" * 5000)
except OutputError as error:
    print(error)
"""


def test_an_atomic_write_that_cannot_finish_names_the_target_and_leaves_nothing(tmp_path):
    path = tmp_path / "report.html"
    path.write_text("the previous report")
    process = subprocess.run(
        [sys.executable, "-c", LIMITED_ATOMIC, str(path)], env=ENV, capture_output=True, text=True
    )
    assert process.stdout.strip() == f"cannot write {path}: the file is too large (EFBIG)", process
    assert path.read_text() == "the previous report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.html"]
