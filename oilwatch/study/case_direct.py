"""The "direct" case: the plant model and the EKF run in-process, without FMI.

The same physics and estimator the two FMUs wrap, called directly, so that the study's accuracy figures can be
measured (and the FMU path later cross-checked against them) without the co-simulation:

* truth: ``oilwatch.models.system.plant.RotorBearingPlant`` on the FULL model (Newmark trapezoidal integration
with
  sub-steps, started in the steady orbit of the case's flowrates), white noise of ``case.noise_um`` on each
  of the four displacement probes, seeded with ``case.rng_seed``; flowrates held constant;
* estimator: ``oilwatch.estimator.ekf.OilFlowEKF`` on ``GridAugmentedModel`` of the REDUCED model (the
estimator's own
  discrete map, not the truth's), configured by ``EKFConfig.preset("paper")`` with the case's noise level, the
  first sample at t = dt (the plant's first output is its state after one step), initial estimate the paper's
  (zero states, each q its bearing's nominal flowrate);
* the record is reduced with :func:`oilwatch.study.cases.reduce_record` (mean after ``case.discard_s``).

The models are built once per process (a Dask worker keeps them between cases).
"""

from __future__ import annotations

import time

import numpy as np

from oilwatch.estimator.ekf import OilFlowEKF
from oilwatch.estimator.ekf_config import EKFConfig
from oilwatch.models.system.augmented import GridAugmentedModel
from oilwatch.models.system.plant import RotorBearingPlant, publish_initial_sample

from .case_cosim import FMI_SEED_MODULUS, ML_MIN_TO_M3_S, full_system
from .cases import CaseResult, reduce_record
from .grid import SAMPLE_DT_S, Case

M3_S_TO_ML_MIN = 1.0 / ML_MIN_TO_M3_S

_ESTIMATOR_MODELS: dict[tuple, GridAugmentedModel] = {}


def estimator_model(machine_file: str | None = None, table_path: str | None = None) -> GridAugmentedModel:
    """The EKF's model (reduced system, flowrate grid of exact discrete maps), built once per process."""
    key = (machine_file, table_path)
    if key not in _ESTIMATOR_MODELS:
        from oilwatch.models.system.factory import load_system

        reduced = load_system(machine_file, reduced=True, table_path=table_path)
        _ESTIMATOR_MODELS[key] = GridAugmentedModel(reduced, SAMPLE_DT_S)
    return _ESTIMATOR_MODELS[key]


def simulate_record(case: Case, system=None) -> np.ndarray:
    """Measured displacements (n_samples, 4) [m] at the case's constant flowrates, t = dt, 2 dt, ... T."""
    flowrates = (case.q1_ml_min * ML_MIN_TO_M3_S, case.q2_ml_min * ML_MIN_TO_M3_S)
    plant = RotorBearingPlant(
        system if system is not None else full_system(case.machine_file or None),
        SAMPLE_DT_S,
        None,
        case.noise_um * 1e-6,
        case.rng_seed % FMI_SEED_MODULUS,  # the plant FMU's seed: the cosim case sees the same noise
        initial_flowrates_m3_s=flowrates,
    )
    publish_initial_sample(plant)  # as the plant FMU does: the FMU path then sees the same noise
    return np.array([plant.step(flowrates).measured_position_m for _ in range(case.n_samples)])


def nuisance_settings(machine_file: str | None) -> dict:
    """EKFConfig fields that make the machine's nuisances unknown states: the four probe offsets with the
    machine file's ``[probes]`` prior and drift, and the complex unbalance (prior std 2, relative to the
    machine file's: ``oilwatch robustness``'s default). The plant has none of them: the study then shows the
    price of not knowing them (the nuisance Cramer-Rao bound), not a discrepancy."""
    from oilwatch.models.machine import load_machine
    from oilwatch.models.probes import read_probes

    probes = read_probes(load_machine(machine_file))
    return {
        "offset_prior_std_m": probes.offset_prior_std_m,
        "offset_random_walk_m_sqrt_s": probes.offset_random_walk_m_sqrt_s,
        "unbalance_prior_std": 2.0,
    }


def run_direct_case(case: Case, nuisances: str = "known") -> CaseResult:
    """One case of the study with the in-process plant and EKF (see the module docstring); ``nuisances``:
    "known" (prior std 0, the paper's calibrated setting) or "unknown" (:func:`nuisance_settings`)."""
    start = time.perf_counter()
    record = simulate_record(case)
    model = estimator_model(case.machine_file or None)
    extra = nuisance_settings(case.machine_file or None) if nuisances == "unknown" else {}
    config = EKFConfig.preset(
        "paper", noise_std_m=case.noise_um * 1e-6, first_sample_time_s=SAMPLE_DT_S, **extra
    )
    trace = OilFlowEKF(model, config).run(record)
    times = SAMPLE_DT_S * np.arange(1, case.n_samples + 1)
    return reduce_record(
        case,
        times,
        trace.q_m3_s * M3_S_TO_ML_MIN,
        trace.q_std_m3_s * M3_S_TO_ML_MIN,
        time.perf_counter() - start,
    )


def run_direct_case_nuisances_unknown(case: Case) -> CaseResult:
    """:func:`run_direct_case` with the nuisances unknown (a picklable module-level callable for Dask)."""
    return run_direct_case(case, nuisances="unknown")
