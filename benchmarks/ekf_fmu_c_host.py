"""The estimator FMU's own step as a compiled FMI host sees it (issue 14: "the estimator FMU's step stays
within 50 us"), beside fmpy's figure.

``tests/c_host/fmi2_host.c`` (a Python-free FMI 2.0 importer, compiled here with ``cc -O2``) runs the plant
FMU and the OilFlowEKF FMU coupled, plant -> estimator, for ``--warmup + --steps`` steps of 1 ms; its
``timing`` directive records, per step of the estimator instance, the CPU time of the host's thread
(CLOCK_THREAD_CPUTIME_ID: the FMU's Python runs on that thread) and the wall time (CLOCK_MONOTONIC) of its
input sets (x1_um, y1_um, x2_um, y2_um, one fmi2SetReal each), fmi2DoStep and output gets (four Reals:
q1/q2 estimate and std, four Booleans: starved1, starved2, converged, measurement_ok), the same calls as
``benchmarks/ekf_step.py``'s FMU row (``FmuLoop``). The estimator runs with its defaults, as in that row:
``bearing_table`` 0, constant conditions (the plant at 80 % flow on both bearings from t = 0, 1 um noise).
The plant's own step and the reads of the values the host carries are outside the timed span.

Printed: median, p10, p90 and mean over the timed steps (after the warm-up), per host run, in us (the mean
is what fmpy's row is: time per pass / steps); with
``--fmpy`` then ``benchmarks/ekf_fmu_step.py --constant-only`` on the same EKF FMU in the same invocation
(its fmpy row is the mean per step of each pass, median over passes), and the 1-min load average.

Usage: ``OPENBLAS_NUM_THREADS=1 python benchmarks/ekf_fmu_c_host.py [--steps 3000] [--warmup 500]
[--runs 3] [--plant-fmu RotorBearingPlant.fmu --ekf-fmu OilFlowEKF.fmu] [--fmpy]``
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S
from oilwatch.models.machine import load_machine

ROOT = Path(__file__).resolve().parent.parent
HOST_SOURCE = ROOT / "tests" / "c_host" / "fmi2_host.c"
STARVED_FRACTION = 0.8
CONNECTED = ("x1_um", "y1_um", "x2_um", "y2_um")
OUTPUT_REALS = ("q1_est_ml_min", "q2_est_ml_min", "q1_std_ml_min", "q2_std_ml_min")
OUTPUT_FLAGS = ("starved1", "starved2", "converged", "measurement_ok")
DT = 1e-3


def plant_parameters() -> dict:
    """The plant at 80 % of the machine file's nominal flowrate from the start (a starved, alarmed state)."""
    starved_ml_min = (
        STARVED_FRACTION
        * load_machine().shared_nominal_flowrate_m3_s("benchmarks/ekf_fmu_c_host.py")
        * ML_MIN_PER_M3_S
    )
    return {
        "q1_final_ml_min": starved_ml_min,
        "q2_final_ml_min": starved_ml_min,
        "fault_time_s": 0.0,
        "fault_duration_s": 1e-3,
    }


def compile_host(folder: Path) -> Path:
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not compiler:
        raise SystemExit("needs the system's C compiler (cc)")
    binary = folder / "fmi2_host"
    subprocess.run([compiler, "-O2", "-Wall", "-o", str(binary), str(HOST_SOURCE), "-ldl"], check=True)
    return binary


def fmu_lines(fmu: Path, folder: Path, instance: str, parameters: dict) -> tuple[list[str], dict[str, int]]:
    """The host's directives for one FMU extracted to ``folder``, and its value references by name."""
    from fmpy import read_model_description

    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
    md = read_model_description(str(fmu))
    variables = {v.name: v for v in md.modelVariables}
    lines = [f"fmu {instance} {folder} {md.coSimulation.modelIdentifier} {md.guid}"]
    for name, value in parameters.items():
        kind = {"Real": "real", "Integer": "integer"}[variables[name].type]
        lines.append(f"{kind} {instance} {variables[name].valueReference} {value!r}")
    return lines, {n: v.valueReference for n, v in variables.items()}


def host_run(host: Path, plant: Path, ekf: Path, folder: Path, steps: int) -> np.ndarray:
    """One coupled run of ``steps`` steps; the estimator's per-step (cpu_ns, wall_ns), shape (steps, 2)."""
    spec, pvr = fmu_lines(plant, folder / "plant", "plant", plant_parameters())
    ekf_spec, evr = fmu_lines(ekf, folder / "ekf", "ekf", {})
    spec += ekf_spec
    spec += [f"connect plant {pvr[n]} ekf {evr[n]}" for n in CONNECTED]
    spec += [f"output ekf {evr[n]} {n}" for n in OUTPUT_REALS]
    spec += [f"boolean ekf {evr[n]} {n}" for n in OUTPUT_FLAGS]
    spec += [f"timing ekf {folder / 'timing.csv'}", f"run {steps * DT!r} {DT!r}"]
    (folder / "spec.txt").write_text("\n".join(spec) + "\n")
    env = {k: v for k, v in os.environ.items() if not k.startswith(("LD_PRELOAD", "PYTHON"))}
    process = subprocess.run(
        [str(host), str(folder / "spec.txt"), str(folder / "out.csv")],
        env=env,
        capture_output=True,
        text=True,
        timeout=1800,
    )
    if process.returncode != 0:
        raise SystemExit(f"the C host failed ({process.returncode}):\n{process.stderr[-3000:]}")
    timing = np.loadtxt(folder / "timing.csv", delimiter=",", skiprows=1, ndmin=2)
    return timing[:, 1:]


def build(folder: Path) -> tuple[Path, Path]:
    sys.path.insert(0, str(ROOT))
    from oilwatch.cosim.fmu_build import build_fmus

    built = build_fmus(folder, only=["RotorBearingPlant", "OilFlowEKF"])
    return next(p for p in built if p.name == "RotorBearingPlant.fmu"), next(
        p for p in built if p.name == "OilFlowEKF.fmu"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=3000, help="timed steps per host run")
    parser.add_argument("--warmup", type=int, default=500, help="untimed steps first")
    parser.add_argument("--runs", type=int, default=3, help="host runs (each a fresh process)")
    parser.add_argument("--plant-fmu", default=None)
    parser.add_argument("--ekf-fmu", default=None)
    parser.add_argument("--fmpy", action="store_true", help="then ekf_fmu_step.py --constant-only, same FMU")
    parser.add_argument("--fmpy-repeats", type=int, default=7)
    args = parser.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

    load = [os.getloadavg()[0]]
    with tempfile.TemporaryDirectory(prefix="oilwatch_c_host_") as tmp:
        tmp = Path(tmp)
        if args.plant_fmu and args.ekf_fmu:
            plant, ekf = Path(args.plant_fmu).resolve(), Path(args.ekf_fmu).resolve()
        else:
            plant, ekf = build(tmp / "fmus")
        host = compile_host(tmp)
        print(f"EKF FMU per step in the C host [us], {args.steps} steps after {args.warmup} of warm-up")
        print(
            f"{'run':<6} {'CPU med':>8} {'p10':>7} {'p90':>7} {'mean':>7}"
            f" {'wall med':>9} {'p10':>7} {'p90':>7} {'mean':>7}"
        )
        every = []
        for run in range(args.runs):
            folder = tmp / f"run{run}"
            folder.mkdir()
            timed = host_run(host, plant, ekf, folder, args.warmup + args.steps)[args.warmup :] / 1e3
            every.append(timed)
            load.append(os.getloadavg()[0])
            print(_row(str(run), timed))
        print(_row("all", np.concatenate(every)))
        print(f"(1-min load average {min(load):.1f}-{max(load):.1f})")
        if args.fmpy:
            command = [
                sys.executable,
                str(ROOT / "benchmarks" / "ekf_fmu_step.py"),
                "--constant-only",
                "--fmu",
                str(ekf),
                "--steps",
                str(args.steps),
                "--repeats",
                str(args.fmpy_repeats),
            ]
            print("\n$ " + " ".join(Path(c).name if c == sys.executable else c for c in command), flush=True)
            subprocess.run(command, check=True)


def _row(label: str, timed: np.ndarray) -> str:
    cpu, wall = timed[:, 0], timed[:, 1]
    q = lambda a: [*np.percentile(a, [50, 10, 90]), a.mean()]  # noqa: E731
    return f"{label:<6} " + "{:8.1f} {:7.1f} {:7.1f} {:7.1f} {:9.1f} {:7.1f} {:7.1f} {:7.1f}".format(
        *q(cpu), *q(wall)
    )


if __name__ == "__main__":
    main()
