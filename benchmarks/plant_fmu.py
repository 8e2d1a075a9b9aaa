"""Real-time factor of the RotorBearingPlant FMU under fmpy (issue 5).

Builds the plant FMU into a temporary folder, then, in one process, for each scenario:

- ``FMU under the oilwatch master``: 20 s at 1 ms, recording the 10 outputs each step (fmpy FMU2Slave);
- ``FMU, bare doStep loop``: fmi2DoStep only, no output read (the FMI floor);
- ``plant model in-process``: ``oilwatch.models.system.plant.RotorBearingPlant.step`` without FMI (the
baseline:
  what the physics alone costs).

Prints the median wall time over the repeats, the real-time factor (simulated / wall seconds) and the
ratio to the in-process baseline. Scenarios: constant flowrates, and the slow drop (4 s sigmoid, where the
flowrates change every step for several seconds and the integrator takes its sub-step path).

Usage: ``OPENBLAS_NUM_THREADS=1 python benchmarks/plant_fmu.py [--duration-s 20] [--repeats 3] [--fmu FILE]``
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO_ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO_ROOT))

from oilwatch.models.machine import load_machine  # noqa: E402

NOMINAL_ML_MIN = load_machine().shared_nominal_flowrate_m3_s("benchmarks/plant_fmu.py") * 6e7
"""The bundled turbine's nominal flowrate [ml/min] (its machine file)."""
SCENARIOS = {
    "constant": {},
    "slow drop": {
        "q1_final_ml_min": 0.75 * NOMINAL_ML_MIN,
        "q2_final_ml_min": 0.75 * NOMINAL_ML_MIN,
        "fault_time_s": 10.0,
        "fault_duration_s": 4.0,
    },
}
OUTPUTS = [
    "x1_um",
    "y1_um",
    "x2_um",
    "y2_um",
    "x1_true_um",
    "y1_true_um",
    "x2_true_um",
    "y2_true_um",
    "q1_ml_min",
    "q2_ml_min",
]


def master_run(fmu: Path, parameters: dict, duration: float) -> float:
    from oilwatch.cosim import FmuSpec, Master, SystemDescription

    system = SystemDescription([FmuSpec("plant", str(fmu), parameters)], connections=[])
    with Master(system) as master:
        start = time.perf_counter()
        master.run(stop_time=duration, step_size=1e-3, record=[f"plant.{o}" for o in OUTPUTS])
        return time.perf_counter() - start


def bare_run(fmu: Path, parameters: dict, duration: float) -> float:
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu))
    unpacked = tempfile.mkdtemp(prefix="oilwatch_plant_fmu_")
    slave = FMU2Slave(
        guid=md.guid,
        unzipDirectory=extract(str(fmu), unpacked),
        modelIdentifier="RotorBearingPlant",
        instanceName="p",
    )
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    refs = {v.name: v.valueReference for v in md.modelVariables}
    for name, value in parameters.items():
        slave.setReal([refs[name]], [value])
    slave.exitInitializationMode()
    steps = round(duration / 1e-3)
    start = time.perf_counter()
    for k in range(steps):
        slave.doStep(k * 1e-3, 1e-3)
    wall = time.perf_counter() - start
    slave.terminate()
    slave.freeInstance()
    shutil.rmtree(unpacked, ignore_errors=True)
    return wall


def model_run(parameters: dict, duration: float) -> float:
    from oilwatch.models.system.factory import load_system
    from oilwatch.models.system.fault import SigmoidFlowrate
    from oilwatch.models.system.plant import RotorBearingPlant

    ml = 1e-6 / 60.0
    p = {
        "q1_initial_ml_min": NOMINAL_ML_MIN,
        "q2_initial_ml_min": NOMINAL_ML_MIN,
        "q1_final_ml_min": NOMINAL_ML_MIN,
        "q2_final_ml_min": NOMINAL_ML_MIN,
        "fault_time_s": 10.0,
        "fault_duration_s": 0.1,
        **parameters,
    }
    schedules = tuple(
        SigmoidFlowrate(
            p[f"q{b}_initial_ml_min"] * ml,
            p[f"q{b}_final_ml_min"] * ml,
            p["fault_time_s"],
            p["fault_duration_s"],
        )
        for b in (1, 2)
    )
    plant = RotorBearingPlant(load_system(reduced=False), 1e-3, schedules, 1e-6, 1)
    start = time.perf_counter()
    for _ in range(round(duration / 1e-3)):
        plant.step()
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration-s", type=float, default=20.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--fmu", default=None, help="RotorBearingPlant.fmu to time (default: build one)")
    args = parser.parse_args()
    sys.path.insert(0, str(REPO_ROOT))
    from oilwatch.cosim.fmu_build import build_fmus

    with tempfile.TemporaryDirectory() as folder:
        if args.fmu is None:
            build_fmus(Path(folder), only=["RotorBearingPlant"], systems=())
        fmu = Path(args.fmu or Path(folder) / "RotorBearingPlant.fmu")
        print(f"RotorBearingPlant FMU, {args.duration_s:g} s at 1 ms, median of {args.repeats} runs")
        print(f"{'scenario':12s} {'run':32s} {'wall s':>8s} {'RTF':>7s} {'vs model':>9s}")
        for scenario, parameters in SCENARIOS.items():
            baseline = statistics.median(model_run(parameters, args.duration_s) for _ in range(args.repeats))
            rows = [
                ("plant model in-process", baseline),
                (
                    "FMU, bare doStep loop",
                    statistics.median(
                        bare_run(fmu, parameters, args.duration_s) for _ in range(args.repeats)
                    ),
                ),
                (
                    "FMU under oilwatch master",
                    statistics.median(
                        master_run(fmu, parameters, args.duration_s) for _ in range(args.repeats)
                    ),
                ),
            ]
            for name, wall in rows:
                print(
                    f"{scenario:12s} {name:32s} {wall:8.2f} {args.duration_s / wall:7.1f} "
                    f"{wall / baseline:9.2f}"
                )


if __name__ == "__main__":
    main()
