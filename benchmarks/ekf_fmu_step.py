"""Where the estimator FMU's step goes under fmpy (issue 14: "the estimator FMU's step stays within 50 us").

One run, the same records, these rows (median over ``--repeats`` passes of the mean cost per step; wall time
and, beside it, the process's CPU time, which a shared machine inflates less):

* the OilFlowEKF FMU under fmpy (``benchmarks/ekf_step.py``'s :class:`FmuLoop`: setReal of the inputs, doStep,
  getReal of four outputs, getBoolean of four flags), ``bearing_table`` 0 on the constant record and 1 on the
  60 s plant ramp record (speed_hz and oil_temperature_c set with every step), with the loader's fast path
  (``fmu_src/slave_base.py``: Get/Set served in C; doStep runs the compiled plain step,
  ``fmu_src/ekf_plain_step.py``, or, when it declines or with ``bearing_table`` 1, the slave's Python step)
  and, further instances of the same FMU, with ``OILWATCH_FMU_FAST_PATH=python`` (Get/Set in C, every doStep
  through the slave's Python step) and ``=0`` (every call through pythonfmu, as before the fast path);
* the same loop without the doStep on the fast instance: the host's own cost of its Get/Set calls (fmpy's
  ctypes marshalling and status checks; the loader's C answer is well under 0.1 us);
* the slave's Python step in this process as the loader calls it (``_fast_step``, after one copy of the
  inputs' row into its input array, which the loader does in C): the shell's Python in doStep;
* the compiled plain step in this process (its C entry through ctypes, after the same copy;
  ``bearing_table`` 0 only);
* the slave's Python methods called as pythonfmu calls them (set_real, do_step, get_real, get_boolean);
* the library step inside it alone (``OilFlowEKF.step`` with the slave's own filter and arguments);
* the bare FMU (``benchmarks/fmus/bare_filter_slave.py``: the same variables, a doStep that does nothing)
  under fmpy and in process: the floor that fmpy, ctypes and pythonfmu's C++ put under any pythonfmu FMU.

So, with the fast path and its Python step: FMU under fmpy = library step + the shell's Python in doStep +
the host's Get/Set + the rest (the loader's doStep: one GIL round trip and call into Python, and the caches
the host's Python evicts), each measured here but the rest; with the compiled step: FMU under fmpy = the
compiled step + the host's Get/Set + the rest (fmpy's doStep call, caches). Without the fast path: library
+ the slave's Python methods + the FMI floor.

Two builds of the same FMU cannot be timed in one process (both bundle the package ``oilwatch``, and the
second is refused when its sources differ): compare another build (e.g. main's) with ``--fmu`` in
alternating runs.

Usage: ``OPENBLAS_NUM_THREADS=1 python benchmarks/ekf_fmu_step.py [--steps 3000] [--repeats 3] [--ramp-s 60]
[--fmu OilFlowEKF.fmu] [--constant-only]``
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np
from ekf_fmu_loop import FmuLoop, bare_fmu, ekf_fmu
from ekf_step import measurements
from ekf_step_ramps import plant_ramp_record

from oilwatch.models.system.augmented import GridAugmentedModel
from oilwatch.models.system.factory import load_system

FAST_PATH_VARIABLE = "OILWATCH_FMU_FAST_PATH"  # fmu_src.slave_base: read when the instance initializes
OUTPUT_REALS = ("q1_est_ml_min", "q2_est_ml_min", "q1_std_ml_min", "q2_std_ml_min")
OUTPUT_FLAGS = ("starved1", "starved2", "converged", "measurement_ok")
DT = 1.0e-3


def _inputs(record: np.ndarray, ramps) -> tuple[list[str], list[list[float]]]:
    """Input names and per-step values [um, Hz, degC] as the FMU loop sets them."""
    samples = (record * 1e6).tolist()
    names = ["x1_um", "y1_um", "x2_um", "y2_um"]
    if ramps is None:
        return names, samples
    rows = [[*row, s, t] for row, s, t in zip(samples, ramps[0].tolist(), ramps[1].tolist(), strict=True)]
    return [*names, "speed_hz", "oil_temperature_c"], rows


def _slave(slave_class, ramps):
    """An initialized slave object of ``slave_class`` (bearing_table 1 at the ramp's start with ``ramps``),
    on the paper preset where it has presets (as :class:`FmuLoop`)."""
    slave = slave_class(instance_name="ekf", resources=None)
    vr = {v.name: v.value_reference for v in slave.vars.values()}
    if "preset" in vr:
        slave.preset = "paper"
    slave.setup_experiment(0.0, None, None)
    if ramps is not None and "bearing_table" in vr:
        slave.set_integer([vr["bearing_table"]], [1])
        slave.set_real([vr["speed_hz"], vr["oil_temperature_c"]], [float(ramps[0][0]), float(ramps[1][0])])
    slave.exit_initialization_mode()
    return slave, vr


def python_path_loop(fmu_path: Path, record: np.ndarray, ramps=None, mode: str = "0") -> FmuLoop:
    """:class:`FmuLoop` on an instance initialized with ``OILWATCH_FMU_FAST_PATH=mode`` (``0``: every call
    through pythonfmu; ``python``: Get/Set in C, every doStep through the slave's Python step)."""
    os.environ[FAST_PATH_VARIABLE] = mode
    try:
        return FmuLoop(fmu_path, record, ramps)
    finally:
        del os.environ[FAST_PATH_VARIABLE]


class InProcess:
    """A slave object called as the FMU loop calls it (``part="slave"``: setReal, doStep, getReal,
    getBoolean through its Python methods; ``part="fast"``: its Python step as the loader's fast path calls
    it; ``part="compiled"``: the compiled plain step, or the Python step when it declines, as the loader
    calls them) or
    its filter's library step alone (``part="library"``: the same samples and operating point as the slave
    hands them to ``OilFlowEKF.step``), fresh and initialized."""

    def __init__(self, slave_class, record: np.ndarray, ramps=None, part: str = "slave") -> None:
        names, self.rows = _inputs(record, ramps)
        self.slave, vr = _slave(slave_class, ramps)
        self.slave.log_queue.clear()  # pythonfmu relays and empties it after each call
        if part in ("fast", "compiled"):  # the rows as the loader leaves them in the input array
            width = len(self.slave.buffered_inputs)
            self.table = np.tile(self.slave.fast_path_buffers()[0][:width], (len(self.rows), 1))
            self.table[:, [self.slave.buffered_inputs.index(n) for n in names]] = self.rows
        self.inputs = [vr[n] for n in names]
        self.reals, self.flags = [vr[n] for n in OUTPUT_REALS], [vr[n] for n in OUTPUT_FLAGS]
        self.part, self.k = part, 0
        self.samples = np.ascontiguousarray(record)  # [m], as the slave hands them to the filter
        self.operating = (
            [(None, None)] * len(record)
            if ramps is None
            else list(zip(ramps[0].tolist(), ramps[1].tolist(), strict=True))
        )

    def run_pass(self) -> tuple[float, float]:
        """One pass over the record: (wall, CPU) time per step [us]."""
        steps = len(self.rows) - 1
        start, cpu = time.perf_counter(), time.process_time()
        if self.part == "library":
            step, samples, operating = self.slave.filter.step, self.samples, self.operating
            for j in range(steps):
                step(samples[j + 1], *operating[j + 1], None)
        elif self.part in ("fast", "compiled"):
            slave, table, k = self.slave, self.table, self.k
            inputs, width = slave.fast_path_buffers()[0], len(slave.buffered_inputs)
            fast_step, plain = slave._fast_step, None
            if self.part == "compiled":
                plain = slave.plain_step_table().step
            for j in range(steps):
                inputs[:width] = table[j + 1]
                inputs[-2] = k * DT
                inputs[-1] = DT
                if plain is None or not plain():
                    fast_step()
                k += 1
            self.k = k
        else:
            slave, inputs, reals, flags, rows, k = (
                self.slave,
                self.inputs,
                self.reals,
                self.flags,
                self.rows,
                self.k,
            )
            for j in range(steps):
                slave.set_real(inputs, rows[j + 1])
                slave.do_step(k * DT, DT)
                slave.get_real(reals)
                slave.get_boolean(flags)
                k += 1
            self.k = k
        return (time.perf_counter() - start) / steps * 1e6, (time.process_time() - cpu) / steps * 1e6

    def close(self) -> None:
        pass


def interleaved(runners: dict, repeats: int) -> dict[str, dict[str, float]]:
    """Passes of every runner in turn, ``repeats`` rounds (load changes hit all alike): per runner the
    median and minimum wall and CPU time per step [us]."""
    passes = {name: [] for name in runners}
    for _ in range(repeats):
        for name, runner in runners.items():
            passes[name].append(runner.run_pass())
    for runner in runners.values():
        runner.close()
    result = {}
    for name, values in passes.items():
        wall, cpu = np.array(values).T
        result[name] = {
            "wall": np.median(wall),
            "wall_min": wall.min(),
            "cpu": np.median(cpu),
            "cpu_min": cpu.min(),
        }
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--ramp-s", type=float, default=60.0, help="length of the plant's ramp record [s]")
    parser.add_argument("--fmu", default=None, help="OilFlowEKF.fmu to time (default: build one)")
    parser.add_argument("--constant-only", action="store_true", help="only the bearing_table 0 record")
    args = parser.parse_args()

    sys.path.insert(0, str(Path(__file__).resolve().parent / "fmus"))
    from bare_filter_slave import BareFilter

    from oilwatch.fmu_src.oilwatch_ekf_slave import OilFlowEKF

    constant = measurements(GridAugmentedModel(load_system(reduced=True)), args.steps)
    cases = [("bearing_table 0, constant", constant, None)]
    if not args.constant_only:
        ramp, speed, temperature = plant_ramp_record(args.ramp_s)
        ramp, ramps = ramp[: args.steps], (speed[: args.steps], temperature[: args.steps])
        cases.append(("bearing_table 1, plant ramps", ramp, ramps))
    load = [os.getloadavg()[0]]
    rows = []
    with tempfile.TemporaryDirectory(prefix="oilwatch_bench_") as folder:
        ekf_path, bare_path = ekf_fmu(args.fmu, folder), bare_fmu(folder)
        for label, record, inputs in cases:
            runners = {"fmu": FmuLoop(ekf_path, record, inputs)}
            runners["python_step"] = python_path_loop(ekf_path, record, inputs, "python")
            runners["python_path"] = python_path_loop(ekf_path, record, inputs)
            runners["host_calls"] = FmuLoop(ekf_path, record, inputs, step=False)
            runners["fast"] = InProcess(OilFlowEKF, record, inputs, part="fast")
            if inputs is None:
                runners["compiled"] = InProcess(OilFlowEKF, record, inputs, part="compiled")
            runners["slave"] = InProcess(OilFlowEKF, record, inputs)
            runners["library"] = InProcess(OilFlowEKF, record, inputs, part="library")
            runners["bare"] = FmuLoop(bare_path, record, inputs)
            runners["bare_slave"] = InProcess(BareFilter, record, inputs)
            t = interleaved(runners, args.repeats)
            load.append(os.getloadavg()[0])
            shell = _difference(t["fast"], t["library"])
            python_step = t["python_step"]
            rest = _difference(_difference(_difference(python_step, t["library"]), shell), t["host_calls"])
            rows += [
                (f"EKF FMU under fmpy, {label} (fast path)", t["fmu"]),
                (f"  the same FMU, {FAST_PATH_VARIABLE}=python (its Python step)", python_step),
                (f"  the same FMU, {FAST_PATH_VARIABLE}=0 (every call through pythonfmu)", t["python_path"]),
                ("  its library step alone (OilFlowEKF.step)", t["library"]),
                ("  the slave's Python step in process as the loader calls it", t["fast"]),
                ("  the host's Get/Set calls alone (the fast instance, no doStep)", t["host_calls"]),
                ("  => shell's Python in doStep (Python step in process - library)", shell),
                ("  => the rest of the Python step (=python - library - shell - host's calls)", rest),
            ]
            if "compiled" in t:
                compiled_rest = _difference(_difference(t["fmu"], t["compiled"]), t["host_calls"])
                rows += [
                    ("  the compiled plain step in process (ctypes call)", t["compiled"]),
                    ("  => the rest (FMU - compiled step - host's calls)", compiled_rest),
                ]
            rows += [
                ("  the slave's Python methods in process (pythonfmu's calls, no FMI)", t["slave"]),
                ("  bare FMU under fmpy, the same calls", t["bare"]),
                ("  bare slave in process", t["bare_slave"]),
                (
                    "  => FMI floor without the fast path (bare under fmpy - bare in process)",
                    _difference(t["bare"], t["bare_slave"]),
                ),
            ]
    header = f"per step [us], {args.repeats} interleaved passes of {args.steps} steps"
    print(f"{header:<78} {'wall':>7} {'min':>7} {'CPU':>7} {'min':>7}")
    for label, c in rows:
        print(f"{label:<78} {c['wall']:7.1f} {c['wall_min']:7.1f} {c['cpu']:7.1f} {c['cpu_min']:7.1f}")
    print(f"(medians and minima over the passes; 1-min load average {min(load):.1f}-{max(load):.1f})")


def _difference(a: dict[str, float], b: dict[str, float]) -> dict[str, float]:
    return {key: a[key] - b[key] for key in a}


if __name__ == "__main__":
    main()
