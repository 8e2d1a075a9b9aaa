"""``oilwatch estimate`` on a long record and on a live pipe: real-time factor, memory, per-sample latency.

1. A record of ``--hours`` (default 1) at 1 kHz, CSV in um: a 10 s run of the in-process plant at nominal
   flow (750 revolutions, so that repeating its true positions keeps the orbit's phase continuous) repeated,
   with fresh 1 um white noise on every sample; written in chunks.
2. ``oilwatch estimate RECORD`` in a subprocess: wall time (whole command, and the summary's estimation time
   after set-up), real-time factor, the child's CPU time (user + system: the real-time factor per core, what
   a shared machine's load does not inflate) and its peak resident memory (``ru_maxrss``).
3. Baseline in the same run: the bare estimator loop (``OilFlowEKF.run_batch`` block by block, the command's
   configuration: the machine file's probe offsets prior) on the first 60 s of the same data in this
   process, CPU time per sample, and the ratio of the command's CPU time per sample to it; the summary's
   ``estimator_s`` (the steps alone, CPU time measured in the command) against its whole estimation CPU
   time, and its ``stages_s``: where the rest goes (reading and conditioning the record, building the rows,
   formatting and writing them, the views' history). CPU time, because on a shared machine the load's
   preemption lands in whichever stage it interrupts.
4. Live: ``oilwatch estimate -`` fed ``--live-s`` seconds of the record line by line at 1 kHz (real-time
   pacing) through a pipe; per-sample latency from writing a line to reading its estimate line back.

Run by hand: ``OPENBLAS_NUM_THREADS=1 python benchmarks/estimate_record.py [--hours 1] [--live-s 20]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

PERIOD_S = 10.0
DT_S = 1e-3
BLOCK_ROWS = 8192
"""The command's chunk of rows (``EstimateOptions.chunk_rows``)."""


def write_long_record(path: Path, hours: float, noise_um: float = 1.0) -> int:
    from fixtures.plant_records import plant_run

    total = round(hours * 3600.0 / DT_S)
    # a record shorter than the period needs only its own length of plant motion
    _, true, _, _ = plant_run(min(PERIOD_S, total * DT_S), DT_S, 0.0, drop_at_s=1e9)
    rows_per_period = true.shape[0]
    rng = np.random.default_rng(7)
    with open(path, "w", encoding="utf-8") as file:
        file.write("time_s,x1_um,y1_um,x2_um,y2_um\n")
        for start in range(0, total, rows_per_period):
            count = min(rows_per_period, total - start)
            t = DT_S * np.arange(start + 1, start + count + 1)
            positions = true[:count] * 1e6 + rng.normal(0.0, noise_um, (count, 4))
            np.savetxt(file, np.column_stack([t, positions]), fmt=["%.3f"] + ["%.5f"] * 4, delimiter=",")
    return total


def bare_estimator_us_per_sample(path: Path, samples: int = 60000) -> float:
    """The bare estimator's loop with the command's configuration (the machine file's offsets prior)."""
    from oilwatch.estimator.ekf import OilFlowEKF
    from oilwatch.models.machine import load_machine
    from oilwatch.models.probes import read_probes
    from oilwatch.monitoring.estimate import estimator_config, estimator_model

    data = np.loadtxt(path, delimiter=",", skiprows=1, max_rows=samples)
    probes = read_probes(load_machine(None))
    ekf = OilFlowEKF(estimator_model(None), estimator_config(75.0, 1.0, 0.0, probes))
    ekf.run_batch(data[:100, 1:] * 1e-6)  # compile
    ekf.reset()
    measured = data[:, 1:] * 1e-6
    trace = None
    started = time.process_time()
    for first in range(0, samples, BLOCK_ROWS):  # as the command: blocks into one reused trace
        trace = ekf.run_batch(measured[first : first + BLOCK_ROWS], out=trace)
    return (time.process_time() - started) / samples * 1e6


def run_command(path: Path, out: Path) -> dict:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", MPLBACKEND="Agg")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    process = subprocess.run(
        [sys.executable, "-m", "oilwatch", "estimate", str(path), "--out", str(out), "--no-progress"],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
    )
    wall = time.perf_counter() - started
    if process.returncode != 0:
        raise SystemExit(process.stderr)
    summary = json.loads((out / "summary.json").read_text())
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall_s": wall, "cpu_s": cpu, "summary": summary, "peak_rss_mb": after.ru_maxrss / 1024.0}


def live_latency(path: Path, out: Path, seconds: float) -> dict:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", MPLBACKEND="Agg")
    with open(path, encoding="utf-8") as file:
        header = file.readline()
        lines = [file.readline() for _ in range(round(seconds / DT_S) + 200)]
    process = subprocess.Popen(
        [sys.executable, "-m", "oilwatch", "estimate", "-", "--out", str(out), "--no-views"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        bufsize=1,
        env=env,
        cwd=ROOT,
    )
    sent = np.full(len(lines), np.nan)
    received = np.full(len(lines), np.nan)
    first_estimate = threading.Event()

    def read():
        process.stdout.readline()  # header
        for i in range(len(lines)):
            line = process.stdout.readline()
            if not line:
                return
            received[i] = time.perf_counter()
            first_estimate.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    process.stdin.write(header)
    warm = 200  # sent at once; the estimator is built and compiled on the first block
    for i in range(warm):
        sent[i] = time.perf_counter()
        process.stdin.write(lines[i])
    process.stdin.flush()
    first_estimate.wait(timeout=300)
    time.sleep(1.0)
    start = time.perf_counter()
    for i in range(warm, len(lines)):
        due = start + (i - warm) * DT_S
        while (now := time.perf_counter()) < due:
            if due - now > 5e-4:
                time.sleep(due - now - 4e-4)
        sent[i] = time.perf_counter()
        process.stdin.write(lines[i])
        process.stdin.flush()
    process.stdin.close()
    reader.join(timeout=120)
    process.wait(timeout=120)
    latency = (received - sent)[warm:] * 1e3
    latency = latency[np.isfinite(latency)]
    return {
        "samples": int(latency.size),
        "median_ms": float(np.median(latency)),
        "p99_ms": float(np.quantile(latency, 0.99)),
        "max_ms": float(latency.max()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--live-s", type=float, default=20.0)
    parser.add_argument("--workdir", help="where the record goes (default: a temporary folder)")
    args = parser.parse_args()
    if args.hours <= 0 or args.live_s < 0:
        parser.error(f"--hours must be > 0 and --live-s >= 0, got {args.hours:g} and {args.live_s:g}")
    if args.workdir is not None and not Path(args.workdir).is_dir():
        parser.error(f"--workdir {args.workdir}: no such folder (create it, or leave the option out)")
    print(f"load average at the start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    with tempfile.TemporaryDirectory(dir=args.workdir) as folder:
        work = Path(folder)
        record = work / "long.csv"
        started = time.perf_counter()
        rows = write_long_record(record, args.hours)
        size_mb = record.stat().st_size / 1e6
        print(f"record: {rows} rows ({size_mb:.0f} MB) written in {time.perf_counter() - started:.0f} s")
        bare = bare_estimator_us_per_sample(record)
        print(f"baseline: bare estimator loop (OilFlowEKF.run_batch, 60 s) {bare:.1f} us/sample CPU")
        result = run_command(record, work / "out")
        summary = result["summary"]
        duration, wall = summary["duration_s"], result["wall_s"]
        samples = summary["samples"]
        per_sample = summary["cpu_s"] / samples * 1e6
        print(
            f"oilwatch estimate: {duration:.0f} s of record in {wall:.1f} s wall (whole command) = "
            f"{duration / wall:.1f}x real time; estimation after set-up {summary['wall_s']:.1f} s wall = "
            f"{summary['realtime_factor']:.1f}x"
        )
        cpu = result["cpu_s"]
        print(
            f"  by CPU: the command used {cpu:.1f} s ({100 * cpu / wall:.0f} % of a core) = "
            f"{duration / cpu:.1f}x real time per core; estimation after set-up {summary['cpu_s']:.1f} s = "
            f"{summary['realtime_factor_cpu']:.1f}x, {per_sample:.1f} us/sample = "
            f"{per_sample / bare:.2f}x the bare estimator"
        )
        share = summary["estimator_s"] / summary["cpu_s"]
        print(
            f"  of which the estimator's steps {summary['estimator_s']:.1f} s CPU ({100 * share:.0f} %): the "
            f"command costs {1 / share:.2f}x its estimator, measured in the same process at the same time"
        )
        stages = {"estimator steps": summary["estimator_s"], **summary["stages_s"]}
        other = summary["cpu_s"] - sum(stages.values())
        print(
            "  where the CPU time goes (us/sample): "
            + ", ".join(f"{name} {seconds / samples * 1e6:.1f}" for name, seconds in stages.items())
            + f", other {other / samples * 1e6:.1f}"
        )
        tenths = summary["cpu_us_per_sample_by_tenth"]
        if tenths:
            print("  CPU per sample along the record, by tenth (us): " + " ".join(f"{v:.1f}" for v in tenths))
        print(f"peak resident memory of the command: {result['peak_rss_mb']:.0f} MB")
        q1, q2 = summary["q1_final_ml_min"], summary["q2_final_ml_min"]
        print(f"final estimates: q1 {q1:.2f}, q2 {q2:.2f} ml/min")
        if args.live_s > 0:
            live = live_latency(record, work / "live", args.live_s)
            print(
                f"stdin at 1 kHz, {live['samples']} samples: latency line in -> estimate line out median "
                f"{live['median_ms']:.2f} ms, p99 {live['p99_ms']:.2f} ms, max {live['max_ms']:.2f} ms"
            )
    print(f"load average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
