"""Cold start and steady step of the FMI 2.0 FMUs under fmpy, beside a baseline build, in one run.

Each sample is a fresh Python process that imports only fmpy and numpy, unpacks the FMU into a new temporary
folder (as fmpy's ``simulate_fmu``, libcosim and most tools do) and times:

* cold start: ``fmi2Instantiate`` -> ``fmi2ExitInitializationMode`` (everything the FMU does before its
  first step: starting its Python code, importing scipy and numba, loading or compiling its kernels,
  building the rotor-bearing model), wall time and, beside it, the process's CPU time over the same span
  (what it takes on an idle core: a shared machine inflates the wall time, much less the CPU time);
* the first step and the hundredth (the estimator's setReal, then doStep and getReal, as in the steady
  step), and the first ``fmi2DoStep`` call alone and the hundredth, wall and thread CPU time (the first one
  must cost no more than the later ones: no hidden compilation, no first-time work);
* the first doStep of a second instance, made in the same process after the first has run and been freed
  (its code loaded and run, the model built): equal to the first instance's first doStep when a fresh
  process does nothing first that a warm one does not, whatever the filter's first samples cost beside its
  later ones;
* the same after other work: three doSteps, each after the host has written and summed
  :data:`EVICTION_BYTES` of memory of its own (as a host does between steps when it runs other models), the
  median of their wall times: what a doStep costs with its code and arrays out of the caches; early (steps
  150-152, in the same phase as the first: the estimator's start bank still runs its five filters) and last
  (three more after the run). A first doStep that costs more than the hundredth but no more than the early
  figure has no first-time work left, only the caches that initialization and the host's own code left
  cold;
* the step: per 1 ms step, the plant's doStep and getReal of its four measured channels, the estimator's
  setReal of its five connected inputs (the plant's record), doStep and getReal of four outputs; mean per
  step from the 200th step to the start bank's choice (:data:`oilwatch.estimator.start_bank.SELECT_S`), and
  the steady step, the mean after it (with ``--steps`` beyond it: the default). At the machine preset the
  first runs five filters and re-centres their operating models, the second one filter;
* the system in libcosim (``OilStarvation.ssp``, the two FMUs in one process, the plant loaded first, so the
  estimator runs on the plant's copy of oilwatch): ``from_ssp_file`` to the end of the first 1 ms step.

The estimator runs twice: at its default preset (``machine``: a start bank of five filters on the model that
follows speed and oil temperature through the first 20 s) and at the ``paper`` preset (one filter on the
flowrate grid at one speed, the compiled plain step). A baseline that predates the presets runs each
preset's configuration through the parameters it had (:func:`preset_parameters`: at ``machine``, the
unbalance and viscosity-factor priors and ``bearing_table`` 1; at ``paper``, its defaults), so each row
compares the same work.

Rows: median over ``--repeats`` processes per FMU and build, the builds alternated, and the ratio
new / baseline.
The baseline is an FMU folder (``--baseline DIR``) or is built here from a git revision
(``--baseline-ref REF``: a detached git worktree of that revision, built by its own ``build.py`` with the
worktree first on ``PYTHONPATH``, then removed). The new FMUs are built from this tree (``--new DIR`` to
reuse a folder).

Usage: ``OPENBLAS_NUM_THREADS=1 python benchmarks/fmu_cold_start.py [--repeats 5] [--steps 25000]
(--baseline DIR | --baseline-ref REF) [--new DIR]``
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from oilwatch.estimator.ekf_config import DEFAULT_PRESET, preset_named
from oilwatch.estimator.start_bank import SELECT_S

ROOT = Path(__file__).resolve().parent.parent
PLANT = "RotorBearingPlant"
ROWS = {
    PLANT: (PLANT, None),
    "OilFlowEKF": ("OilFlowEKF", DEFAULT_PRESET),
    "OilFlowEKF paper": ("OilFlowEKF", "paper"),
}
"""Each row's label: (FMU, the estimator's preset); the last is the estimator at the ``paper`` preset (module
docstring)."""


def preset_parameters(name: str | None) -> dict[str, dict[str, object]]:
    """The FMU parameters that select the preset ``name`` (None: none): ``with_presets``, for a build that
    has the ``preset`` parameter, and ``before_presets``, the same configuration for a build that predates
    it: the preset's numeric fields and ``bearing_table`` (1 where the preset follows the operating point),
    each set where that build declares it (the rest were that build's only behaviour)."""
    if name is None:
        return {"with_presets": {}, "before_presets": {}}
    preset = preset_named(name)
    before = {
        field: value
        for field, value in preset.fields
        if isinstance(value, int | float) and not isinstance(value, bool)
    }
    before["bearing_table"] = int(preset.follow_operating_point)
    return {"with_presets": {"preset": name}, "before_presets": before}


EVICTION_BYTES = 32 * 2**20
BANK_STEPS = round(SELECT_S / 1e-3)
"""1 ms steps to the start bank's choice: the step figures before and after it."""
DEFAULT_STEPS = BANK_STEPS + 5000
SYSTEM = "SSP in libcosim"
CHANNELS = ("x1_um", "y1_um", "x2_um", "y2_um")
CONNECTED = (*CHANNELS, "t_sample_s")
EKF_OUTPUTS = ("q1_est_ml_min", "q2_est_ml_min", "q1_std_ml_min", "q2_std_ml_min")

CHILD = r"""
import json, sys, tempfile, time
import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

fmu_path, record_path, steps = sys.argv[1], sys.argv[2], int(sys.argv[3])
names = json.loads(sys.argv[4])
parameters, eviction_bytes, bank_steps = json.loads(sys.argv[5]), int(sys.argv[6]), int(sys.argv[7])
md = read_model_description(fmu_path)
vr = {v.name: v.valueReference for v in md.modelVariables}
kinds = {v.name: v.type for v in md.modelVariables}
folder = extract(fmu_path, tempfile.mkdtemp(prefix="cold_start_"))


def slave(name):  # the unpacked FMU's library, loaded for an instance called name
    return FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier,
                     instanceName=name)


def initialize(fmu):  # instantiate, set the preset's parameters, initialize
    fmu.instantiate()
    # a build that predates the presets gets the preset's configuration through the parameters it had
    chosen = parameters["with_presets" if "preset" in vr else "before_presets"]
    setters = {"Real": fmu.setReal, "Integer": fmu.setInteger, "String": fmu.setString}
    for key, value in chosen.items():
        if key in vr:
            setters[kinds[key]]([vr[key]], [value])
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()


fmu = slave("instance")
start, cpu = time.perf_counter(), time.process_time()
initialize(fmu)
cold, cold_cpu = time.perf_counter() - start, time.process_time() - cpu
plant = "q1_est_ml_min" not in vr
if plant:
    outputs, inputs, rows = [vr[n] for n in names["channels"]], [], None
else:
    outputs, inputs = [vr[n] for n in names["ekf_outputs"]], [vr[n] for n in names["connected"]]
    rows = np.load(record_path)
# arrays, not lists of row lists: the garbage collector would walk those on every full collection, which
# slowed the host's steps as the list grew (the plant's step 112 us to 20 s, 139 us after)
recorded = np.empty((steps + 3, len(names["channels"]) + 1)) if plant else None
durations, calls = [], []
other = np.empty(eviction_bytes // 8)
early = (150, 151, 152)  # steps >= 300: before the start bank's choice
for k in range(steps):
    if k in early:
        other[:] = k  # the host's own work between two steps
        other.sum()
    begin = time.perf_counter()
    if inputs:
        fmu.setReal(inputs, rows[k].tolist())
    call, call_cpu = time.perf_counter(), time.thread_time()
    fmu.doStep(k * 1e-3, 1e-3)
    calls.append((time.perf_counter() - call, time.thread_time() - call_cpu))
    values = fmu.getReal(outputs)
    durations.append(time.perf_counter() - begin)
    if plant:
        recorded[k] = [*values, fmu.getReal([vr["t_sample_s"]])[0]]
evicted = []
for k in range(steps, steps + 3):
    other[:] = k
    other.sum()
    if inputs:
        fmu.setReal(inputs, rows[k].tolist())
    call = time.perf_counter()
    fmu.doStep(k * 1e-3, 1e-3)
    evicted.append(time.perf_counter() - call)
    if plant:
        recorded[k] = [*fmu.getReal(outputs), fmu.getReal([vr["t_sample_s"]])[0]]
if plant and record_path:
    np.save(record_path, recorded)
fmu.terminate()
fmu.freeInstance()
# a second instance in this process, whose code and model every step above has run: its first doStep
# against the first instance's separates what a fresh process still does first from the filter's own
# first samples
second = slave("second")
initialize(second)
if inputs:
    second.setReal(inputs, rows[0].tolist())
call = time.perf_counter()
second.doStep(0.0, 1e-3)
second_call = time.perf_counter() - call
print(json.dumps({"cold_s": cold, "cold_cpu_s": cold_cpu, "first_s": durations[0],
                  "hundredth_s": durations[99], "first_call_s": calls[0][0], "hundredth_call_s": calls[99][0],
                  "first_call_cpu_s": calls[0][1], "hundredth_call_cpu_s": calls[99][1],
                  "evicted_call_s": float(np.median(evicted)), "second_instance_call_s": second_call,
                  "early_evicted_call_s": float(np.median([calls[k][0] for k in early])),
                  "bank_us": 1e6 * float(np.mean(durations[200:bank_steps])),
                  "steady_us": 1e6 * float(np.mean(durations[bank_steps:])) if steps > bank_steps else None}))
"""


LIBCOSIM_CHILD = r"""
import json, os, sys, time
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

log_output_level(CosimLogLevel.ERROR)
start, cpu = time.perf_counter(), time.process_time()
execution = CosimExecution.from_ssp_file(sys.argv[1], step_size=1_000_000)
execution.simulate_until(1_000_000)
print(json.dumps({"cold_s": time.perf_counter() - start, "cold_cpu_s": time.process_time() - cpu}))
sys.stdout.flush()
os._exit(0)
"""


def libcosim_sample(ssp: Path) -> dict:
    """One fresh process: libcosim unpacks ``ssp``'s FMUs into new folders and runs its first step."""
    with tempfile.TemporaryDirectory(prefix="cold_start_cwd_") as cwd:
        arguments = [sys.executable, "-c", LIBCOSIM_CHILD, str(ssp)]
        process = subprocess.run(arguments, capture_output=True, text=True, env=environment(cwd), cwd=cwd)
    if process.returncode != 0:
        raise SystemExit(f"{ssp}: the libcosim child failed:\n{process.stderr[-3000:]}")
    return json.loads(process.stdout.strip().splitlines()[-1])


def environment(scratch: str | None = None) -> dict[str, str]:
    """This environment with one BLAS thread and nothing that points the FMU at a source tree; with
    ``scratch``, the child's temporary files there (its FMU unpacks and libcosim's, which a child that
    exits at once leaves behind: the caller removes ``scratch``)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(OPENBLAS_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    if scratch is not None:
        env["TMPDIR"] = scratch
    return env


def sample(fmu: Path, record: str, steps: int, preset: str | None = None) -> dict:
    """One fresh process, one fresh unpack of ``fmu`` (see the module docstring). ``record``: the plant
    record the estimator reads, or the plant writes (empty: the plant writes none); ``preset``: the
    estimator's, set in initialization (:func:`preset_parameters`)."""
    names = json.dumps({"channels": CHANNELS, "ekf_outputs": EKF_OUTPUTS, "connected": CONNECTED})
    with tempfile.TemporaryDirectory(prefix="cold_start_cwd_") as cwd:
        arguments = [sys.executable, "-c", CHILD, str(fmu), record, str(steps), names,
                     json.dumps(preset_parameters(preset)), str(EVICTION_BYTES), str(BANK_STEPS)]  # fmt: skip
        process = subprocess.run(arguments, capture_output=True, text=True, env=environment(cwd), cwd=cwd)
    if process.returncode != 0:
        raise SystemExit(f"{fmu}: the child failed:\n{process.stderr[-3000:]}")
    return json.loads(process.stdout.strip().splitlines()[-1])


def build(out: Path, source: Path) -> Path:
    """The FMUs built by ``source``'s own build.py (first on PYTHONPATH) into ``out``."""
    env = environment()
    env["PYTHONPATH"] = str(source)
    process = subprocess.run(
        [sys.executable, str(source / "build.py"), "--out", str(out)], cwd=source, env=env,
        capture_output=True, text=True,
    )  # fmt: skip
    if process.returncode != 0:
        raise SystemExit(f"building the FMUs in {source} failed:\n{process.stderr[-3000:]}")
    return out


def baseline_build(ref: str, out: Path) -> Path:
    """The FMUs of the git revision ``ref``, built in a detached git worktree that is removed afterwards."""
    tree = Path(tempfile.mkdtemp(prefix="cold_start_baseline_")) / "tree"
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(tree), ref], check=True,
                   capture_output=True)  # fmt: skip
    try:
        return build(out, tree)
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)], check=False)
        shutil.rmtree(tree.parent, ignore_errors=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5, help="fresh processes per FMU and build")
    parser.add_argument(
        "--steps",
        type=int,
        default=DEFAULT_STEPS,
        help=f"1 ms steps per process (at least 300; beyond {BANK_STEPS} for the steady step)",
    )
    baseline = parser.add_mutually_exclusive_group(required=True)
    baseline.add_argument("--baseline", type=Path, help="folder of the baseline FMUs")
    baseline.add_argument("--baseline-ref", help="git revision the baseline FMUs are built from")
    parser.add_argument(
        "--new", type=Path, help="folder of the new FMUs (default: build them from this tree)"
    )
    args = parser.parse_args()
    steps = max(args.steps, 300)
    work = Path(tempfile.mkdtemp(prefix="cold_start_fmus_"))
    try:
        measure(args, steps, work)
    finally:
        shutil.rmtree(work, ignore_errors=True)  # the builds and the record: 50-100 MB a run


def measure(args, steps: int, work: Path) -> None:
    """Build (or take) both sets of FMUs into ``work``, sample them and print the table."""
    builds = {
        "baseline": args.baseline or baseline_build(args.baseline_ref, work / "baseline"),
        "new": args.new or build(work / "new", ROOT),
    }
    record = work / "plant_record.npy"
    sample(builds["new"] / f"{PLANT}.fmu", str(record), steps)
    rows = tuple(ROWS)
    results = {(name, row): [] for name in builds for row in (*rows, SYSTEM)}
    for _ in range(args.repeats):
        for row, (fmu, preset) in ROWS.items():
            for name, folder in builds.items():
                results[name, row].append(
                    sample(folder / f"{fmu}.fmu", "" if fmu == PLANT else str(record), steps, preset)
                )
        for name, folder in builds.items():
            results[name, SYSTEM].append(libcosim_sample(folder / "OilStarvation.ssp"))
    load = os.getloadavg()[0]
    print(f"fresh unpack, fresh process, median of {args.repeats}; 1-min load average {load:.2f}")
    print(f"baseline: {builds['baseline']}  new: {builds['new']}")
    header = f"{'FMU':18s} {'figure':30s} {'baseline':>10s} {'new':>10s} {'new/base':>9s}"
    print(header)
    figures = (("cold start [s]", "cold_s", 1.0), ("cold start, CPU [s]", "cold_cpu_s", 1.0),
               ("first step [ms]", "first_s", 1e3), ("100th step [ms]", "hundredth_s", 1e3),
               ("first doStep [ms]", "first_call_s", 1e3), ("100th doStep [ms]", "hundredth_call_s", 1e3),
               ("first doStep, CPU [ms]", "first_call_cpu_s", 1e3),
               ("100th doStep, CPU [ms]", "hundredth_call_cpu_s", 1e3),
               ("first doStep, second instance [ms]", "second_instance_call_s", 1e3),
               ("doStep after 32 MB, early [ms]", "early_evicted_call_s", 1e3),
               ("doStep after 32 MB, last [ms]", "evicted_call_s", 1e3),
               (f"step to {SELECT_S:g} s [us]", "bank_us", 1.0),
               (f"step after {SELECT_S:g} s [us]", "steady_us", 1.0))  # fmt: skip
    for row in rows:
        for label, key, scale in figures:
            if results["new", row][0].get(key) is None:  # --steps short of the start bank's choice
                continue
            old = statistics.median(r[key] for r in results["baseline", row]) * scale
            new = statistics.median(r[key] for r in results["new", row]) * scale
            print(f"{row:18s} {label:30s} {old:10.3f} {new:10.3f} {new / old:9.3f}")
    for label, key, scale in figures[:2]:
        old = statistics.median(r[key] for r in results["baseline", SYSTEM]) * scale
        new = statistics.median(r[key] for r in results["new", SYSTEM]) * scale
        print(f"{SYSTEM:18s} {label:30s} {old:10.3f} {new:10.3f} {new / old:9.3f}")


if __name__ == "__main__":
    main()
