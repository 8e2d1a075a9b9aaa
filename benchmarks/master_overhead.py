"""Per-step overhead of the oilwatch co-simulation master, with the toy FMUs.

Runs, in one process, on ToyPlant -> ToyFilter (1 ms macro steps):

- ``bare doStep``: only fmi2DoStep on both FMUs (the floor set by fmpy + pythonfmu);
- ``naive fmpy loop``: the loop one writes with fmpy's high-level API (doStep, getReal, setReal);
- ``master, no recording`` and ``master, all outputs``: :class:`oilwatch.cosim.Master` in
  Gauss-Seidel order (``Jacobi`` too);
- ``libcosim step()``: the same system as an .ssp in libcosim (libcosimpy), for comparison.

Prints the median microseconds per macro step over the repeats, and ratios to the baselines.
Usage: ``OPENBLAS_NUM_THREADS=1 python benchmarks/master_overhead.py [--steps 5000] [--repeats 5]``
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO_ROOT / "tests"))


def _raw_slaves(folder: Path):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    slaves = {}
    for name in ("ToyPlant", "ToyFilter"):
        path = str(folder / f"{name}.fmu")
        md = read_model_description(path)
        unpacked = extract(path, str(folder / f"{name}_unpacked"))  # inside the run's folder, removed with it
        slave = FMU2Slave(guid=md.guid, unzipDirectory=unpacked, modelIdentifier=name, instanceName=name)
        slave.instantiate()
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        vrs = {v.name: v.valueReference for v in md.modelVariables}
        slaves[name] = (slave, vrs)
    return slaves


def bare_loop(slaves, steps: int, h: float) -> float:
    plant, _ = slaves["ToyPlant"]
    filt, _ = slaves["ToyFilter"]
    start = time.perf_counter()
    for k in range(steps):
        plant.doStep(k * h, h)
        filt.doStep(k * h, h)
    return time.perf_counter() - start


def naive_loop(slaves, steps: int, h: float) -> float:
    plant, pv = slaves["ToyPlant"]
    filt, fv = slaves["ToyFilter"]
    out, into = [pv["y_um"]], [fv["y_um"]]
    start = time.perf_counter()
    for k in range(steps):
        plant.doStep(k * h, h)
        filt.setReal(into, plant.getReal(out))
        filt.doStep(k * h, h)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    from fixtures.toy_fmus import build_toys
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    from oilwatch.cosim import FmuSpec, Master, SystemDescription
    from oilwatch.cosim.ssp import write_ssp

    h = 1e-3
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        build_toys(folder)
        slaves = _raw_slaves(folder)
        system = SystemDescription(
            [FmuSpec("plant", folder / "ToyPlant.fmu"), FmuSpec("filt", folder / "ToyFilter.fmu")]
        )
        cases = {
            "bare doStep x2": lambda: bare_loop(slaves, args.steps, h),
            "naive fmpy loop": lambda: naive_loop(slaves, args.steps, h),
        }
        with Master(system) as master:
            everything = master.default_record()

            def run(method, record):
                return master.run(args.steps * h, h, method=method, record=record).wall_s

            cases["master GS, no recording"] = lambda: run("gauss-seidel", [])
            cases["master Jacobi, no recording"] = lambda: run("jacobi", [])
            cases[f"master GS, {len(everything)} outputs"] = lambda: run("gauss-seidel", everything)
            ssp = write_ssp(folder / "Toy.ssp", system)
            log_output_level(CosimLogLevel.ERROR)
            execution = CosimExecution.from_ssp_file(str(ssp), step_size=round(h * 1e9))

            def libcosim():
                start = time.perf_counter()
                execution.step(args.steps)
                return time.perf_counter() - start

            cases["libcosim step()"] = libcosim
            timings = {name: [] for name in cases}
            for _ in range(args.repeats):
                for name, case in cases.items():
                    timings[name].append(case() / args.steps * 1e6)
    medians = {name: statistics.median(values) for name, values in timings.items()}
    bare, naive = medians["bare doStep x2"], medians["naive fmpy loop"]
    print(f"{args.steps} steps x {args.repeats} repeats, 2 FMUs, 1 connection")
    print(f"{'case':32s} {'us/step':>9s} {'/bare':>7s} {'/naive':>7s} {'over bare':>10s}")
    for name, value in medians.items():
        print(f"{name:32s} {value:9.2f} {value / bare:7.2f} {value / naive:7.2f} {value - bare:10.2f}")


if __name__ == "__main__":
    main()
