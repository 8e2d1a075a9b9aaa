"""The EKF step benchmark's rows under speed and oil-temperature ramps (issue 13) and with nuisance states.

The plant's ramp record (:func:`plant_ramp_record`: full-order Newmark plant on the dimensionless table, the
speed up and down between 72 and 78 Hz at 1 Hz/s, the oil warming by 10 degC per minute), the estimator on
the operating model fed the same speed and temperature, and the reference grid with the probe-offset and
unbalance states (:func:`offset_rows`). Run through ``benchmarks/ekf_step.py``.
"""

from __future__ import annotations

import tempfile

import numpy as np
from ekf_fmu_loop import bare_fmu, ekf_fmu, time_fmu
from step_timing import clock, time_per_step

from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.models.machine import load_machine
from oilwatch.models.system.factory import load_system

RAMP_HZ_PER_S = 1.0
WARMING_C_PER_S = 10.0 / 60.0
RAMP_HZ = (72.0, 78.0)
RAMP_FLOWRATES = (0.8, 0.9)
"""The plant's constant flowrates in the ramp record (fractions of nominal)."""


def ramp_inputs(steps: int, nominal_c: float, dt: float = 1.0e-3) -> tuple[np.ndarray, np.ndarray]:
    """Speed [Hz] and oil temperature [degC] of samples k = 1 .. steps: the speed ramps up and down between
    72 and 78 Hz at 1 Hz/s (a triangle wave, continuous), the oil warms by 10 degC per minute."""
    t = np.arange(1, steps + 1) * dt
    period = 2.0 * (RAMP_HZ[1] - RAMP_HZ[0]) / RAMP_HZ_PER_S
    phase = t % period
    return RAMP_HZ[0] + RAMP_HZ_PER_S * np.minimum(phase, period - phase), nominal_c + WARMING_C_PER_S * t


def plant_ramp_record(seconds: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(displacements (K, 4) [m], speed (K,) [Hz], oil temperature (K,) [degC]) of the plant (full-order
    Newmark model on the dimensionless table, 1 um noise) under :func:`ramp_inputs` at
    :data:`RAMP_FLOWRATES`, samples t = 1 ms .. seconds: what a machine would give the estimator, which is fed
    the same speed and temperature. Cached in ``<cache>/benchmarks`` (the plant takes minutes)."""
    from oilwatch.models.cache import user_cache_dir
    from oilwatch.models.system.operating_point import operating_system
    from oilwatch.models.system.plant import RotorBearingPlant

    machine = load_machine()
    nominal_c = machine.nominal_oil_temperature_c
    steps = round(seconds / 1.0e-3)
    path = user_cache_dir() / "benchmarks" / f"ekf_ramp_record_{steps}.npz"
    if path.exists():
        stored = np.load(path)
        return stored["displacements"], stored["speed_hz"], stored["oil_temperature_c"]
    speed, temperature = ramp_inputs(steps, nominal_c)
    q = tuple(
        f * machine.shared_nominal_flowrate_m3_s("benchmarks/ekf_step_ramps.py") for f in RAMP_FLOWRATES
    )
    system = operating_system(machine, RAMP_HZ[0], machine.oil.dynamic_viscosity_pa_s(nominal_c))
    plant = RotorBearingPlant(
        system, 1e-3, None, 1e-6, 3, initial_flowrates_m3_s=q, oil=machine.oil, oil_temperature_c=nominal_c
    )
    displacements = np.empty((steps, 4))
    for k in range(steps):
        if k % (steps // 10) == 0:
            print(f"  plant ramp record: {k / steps:4.0%}", flush=True)
        sample = plant.step(q, speed_hz=float(speed[k]), oil_temperature_c=float(temperature[k]))
        displacements[k] = sample.measured_position_m
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez(path, displacements=displacements, speed_hz=speed, oil_temperature_c=temperature)
    return displacements, speed, temperature


class _RampFilter:
    """An OilFlowEKF fed a record's measured speed and oil temperature with every sample."""

    def __init__(self, model, config: EKFConfig, speed: np.ndarray, temperature: np.ndarray) -> None:
        self.ekf = OilFlowEKF(model, config)
        self.inputs = list(zip(speed.tolist(), temperature.tolist(), strict=True))
        self.k = 0

    def step(self, z: np.ndarray) -> None:
        speed, temperature = self.inputs[self.k]
        self.ekf.step(z, speed, temperature)
        self.k += 1


def operating_rows(args, record: np.ndarray) -> list[tuple[str, tuple[float, float]]]:
    """The estimator on the plant's ramp record (:func:`plant_ramp_record`, ``--ramp-s`` long), fed the
    measured speed and oil temperature, beside the same filter on the reference grid at constant conditions
    (``record``), re-centrings included in the mean; the FMU the same way."""
    from oilwatch.models.system.operating_model import build_operating_model

    machine = load_machine()
    model = build_operating_model(load_system(reduced=True), machine)
    ramp, speed, temperature = plant_ramp_record(args.ramp_s)
    config = EKFConfig(
        velocity_noise="displacement-only", gate_tail_probability=0.0, first_sample_time_s=1e-3
    )
    factors = EKFConfig.recommended(viscosity_factor_prior_std=0.05, first_sample_time_s=1e-3)
    for c in (config, factors):
        _RampFilter(model, c, speed, temperature).ekf.run(ramp[:10])  # compile outside the timing
    rows = [
        (
            "OilFlowEKF, reference grid (26 states), constant",
            time_per_step(lambda: OilFlowEKF(model.reference, config), record, args.repeats),
        )
    ]
    rows += offset_rows(model.reference, machine, record, args.repeats)
    label = f"{args.ramp_s:g} s plant ramps 1 Hz/s + 10 degC/min"
    for name, c in (("", config), (", viscosity factors estimated", factors)):
        before = model.recentre_count
        cost = time_per_step(lambda c=c: _RampFilter(model, c, speed, temperature), ramp, args.repeats)
        rows.append((f"OilFlowEKF, operating model, {label}{name}", cost))
        passes = (model.recentre_count - before) / args.repeats
        print(f"(operating model{name}: {passes:.0f} re-centrings per pass)")
    costs = []
    for k in range(max(args.repeats, 10)):
        # a new centre each time (as under a ramp: new table slices at the new speed and viscosities)
        q = 0.8 * model.nominal_flowrates_m3_s
        centre = np.array([*q, 74.0 + 0.05 * k, -2.5 + 0.005 * k, -2.5 - 0.005 * k])
        start = clock()
        model.place_centre(centre)
        costs.append((clock() - start) * 1e6)
    rows.append(
        ("one re-centring of the operating model (a new centre each)", (np.median(costs), min(costs)))
    )
    if args.library_only:
        return rows
    with tempfile.TemporaryDirectory(prefix="oilwatch_bench_") as folder:
        path = ekf_fmu(args.fmu, folder)
        rows.append(
            ("OilFlowEKF FMU under fmpy, bearing_table 0, constant", time_fmu(path, record, args.repeats))
        )
        rows.append(
            (
                f"OilFlowEKF FMU under fmpy, bearing_table 1, {label}",
                time_fmu(path, ramp, args.repeats, ramps=(speed, temperature)),
            )
        )
        rows.append(
            (
                "bare FMU under fmpy (doStep does nothing), the same calls with the ramps' inputs",
                time_fmu(bare_fmu(folder), ramp, args.repeats, ramps=(speed, temperature)),
            )
        )
    return rows


def offset_rows(reference, machine, record: np.ndarray, repeats: int) -> list[tuple[str, tuple]]:
    """The reference grid with the four probe-offset states of ``oilwatch estimate`` (the machine file's
    [probes] prior), per step and through :meth:`OilFlowEKF.run_batch` (its per-block entry), and with the
    complex unbalance estimated as well."""
    from oilwatch.models.probes import read_probes
    from oilwatch.monitoring.estimate import estimator_config

    offsets = estimator_config(machine.nominal_speed_hz, 1.0, 0.0, read_probes(machine))
    both = EKFConfig.recommended(offset_prior_std_m=5e-6, unbalance_prior_std=0.3)
    for c in (offsets, both):
        OilFlowEKF(reference, c).run(record[:10])  # compile outside the timing
    label = "OilFlowEKF, reference grid + 4 probe offsets (estimate's config)"
    rows = [(label, time_per_step(lambda: OilFlowEKF(reference, offsets), record, repeats))]
    if hasattr(OilFlowEKF, "run_batch"):  # absent before the batch entry (timing an older checkout)
        samples = []
        for _ in range(repeats):
            ekf = OilFlowEKF(reference, offsets)
            start = clock()
            for block in range(0, len(record), 1000):
                ekf.run_batch(record[block : block + 1000])
            samples.append((clock() - start) / len(record) * 1e6)
        batch = (np.median(samples), np.min(samples))
        rows.append(("the same through run_batch, 1000 samples per call", batch))
    cost = time_per_step(lambda: OilFlowEKF(reference, both), record, repeats)
    return [*rows, ("OilFlowEKF, reference grid + 4 probe offsets + unbalance", cost)]
