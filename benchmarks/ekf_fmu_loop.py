"""The OilFlowEKF FMU (and the bare FMU whose doStep does nothing) timed under fmpy, for the EKF step
benchmarks (``benchmarks/ekf_step.py``, ``benchmarks/ekf_fmu_step.py``): :class:`FmuLoop`, a plain
``FMU2Slave`` loop over a record, and the FMUs it times, built on demand."""

from __future__ import annotations

import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


class FmuLoop:
    """One instance of an EKF-like FMU (or the bare one) under fmpy's ``FMU2Slave``, initialized, and the
    benchmark's loop over a record: setReal of the four positions (and, with ``ramps``, speed_hz and
    oil_temperature_c), doStep, getReal of the estimates and stds, getBoolean of four flags.

    ``record[k]`` is the model's output at t_k = k dt; doStep(t, dt) gets the sample of t + dt (the FMU's
    unconnected ``t_sample_s``), so the filter sees aligned data. The instance runs on through the passes.
    ``ramps``: the record's speed [Hz] and oil temperature [degC] (K,) each; the FMU then runs with
    ``bearing_table = 1`` and gets them on its inputs with every step (setReal included in the cost).
    ``step=False`` leaves out the doStep: the host's Get/Set calls alone. ``preset``: the estimator FMU's
    ``preset`` parameter when it has one (``paper``: the configuration of an FMU built before the presets,
    whose defaults were the paper's calibrated filter, so that two builds are timed alike).
    """

    def __init__(
        self,
        fmu_path: Path,
        record: np.ndarray,
        ramps=None,
        dt: float = 1.0e-3,
        step: bool = True,
        preset: str = "paper",
    ) -> None:
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        md = read_model_description(str(fmu_path))
        bare = md.coSimulation.modelIdentifier == "BareFilter"
        self.unpacked = tempfile.mkdtemp(prefix="oilwatch_fmu_loop_")  # removed by close()
        self.fmu = fmu = FMU2Slave(
            guid=md.guid,
            unzipDirectory=extract(str(fmu_path), self.unpacked),
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName="ekf",
        )
        vr = {v.name: v.valueReference for v in md.modelVariables}
        names = ["x1_um", "y1_um", "x2_um", "y2_um"] + (["speed_hz", "oil_temperature_c"] if ramps else [])
        self.inputs = [vr[n] for n in names]
        self.reals = [vr[n] for n in ("q1_est_ml_min", "q2_est_ml_min", "q1_std_ml_min", "q2_std_ml_min")]
        self.flags = [vr[n] for n in ("starved1", "starved2", "converged", "measurement_ok")]
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        if "preset" in vr:
            fmu.setString([vr["preset"]], [preset])
        if ramps is not None and not bare:
            fmu.setInteger([vr["bearing_table"]], [1])
            fmu.setReal([vr["speed_hz"], vr["oil_temperature_c"]], [float(ramps[0][0]), float(ramps[1][0])])
        fmu.exitInitializationMode()  # builds the model and compiles (or loads) the numba kernels
        samples = (record * 1e6).tolist()
        if ramps is not None:
            operating = zip(ramps[0].tolist(), ramps[1].tolist(), strict=True)
            samples = [[*row, *point] for row, point in zip(samples, operating, strict=True)]
        self.samples, self.dt, self.k, self.step = samples, dt, 0, step

    def run_pass(self) -> tuple[float, float]:
        """One pass over the record: (wall, CPU) time per step [us]."""
        fmu, inputs, reals, flags, samples, dt = (
            self.fmu,
            self.inputs,
            self.reals,
            self.flags,
            self.samples,
            self.dt,
        )
        steps, k, step = len(samples) - 1, self.k, self.step
        start, cpu = time.perf_counter(), time.process_time()
        for j in range(steps):
            fmu.setReal(inputs, samples[j + 1])
            if step:
                fmu.doStep(k * dt, dt)
            fmu.getReal(reals)
            fmu.getBoolean(flags)
            k += 1
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu
        self.k = k
        return wall / steps * 1e6, cpu / steps * 1e6

    def close(self) -> None:
        """End the instance and remove its unpacked FMU."""
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.unpacked, ignore_errors=True)


def time_fmu(
    fmu_path: Path,
    record: np.ndarray,
    repeats: int,
    ramps: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[float, float]:
    """Median and minimum over ``repeats`` passes of ``record`` of the wall time per FMU step [us] of
    :class:`FmuLoop`'s loop (setReal, doStep, getReal, getBoolean)."""
    loop = FmuLoop(fmu_path, record, ramps)
    samples_us = [loop.run_pass()[0] for _ in range(repeats)]
    loop.close()
    return float(np.median(samples_us)), float(np.min(samples_us))


def bare_fmu(out_dir: str) -> Path:
    """BareFilter.fmu (``benchmarks/fmus/bare_filter_slave.py``: the same inputs, a doStep that does nothing),
    built now."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from oilwatch.cosim.fmu_build import FmuEntry, build_fmus

    entry = FmuEntry(
        name="BareFilter",
        script=str(Path(__file__).resolve().parent / "fmus" / "bare_filter_slave.py"),
    )
    return next(p for p in build_fmus(out_dir, only=["BareFilter"], extra=(entry,)) if p.suffix == ".fmu")


def ekf_fmu(path: str | None, out_dir: str) -> Path:
    """The EKF FMU to time: ``path``, or one built now into ``out_dir``."""
    if path is not None:
        return Path(path)
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from oilwatch.cosim.fmu_build import build_fmus

    return next(p for p in build_fmus(out_dir, only=["OilFlowEKF"]) if p.suffix == ".fmu")
