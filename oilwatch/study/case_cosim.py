"""The co-simulated case: the plant FMU and the estimator FMU through oilwatch's fmpy master.

The study's default case model (``oilwatch study --case cosim``): each case runs RotorBearingPlant.fmu and
OilFlowEKF.fmu, connected by name (``x1_um`` ... ``y2_um``, ``t_sample_s``), with the Gauss-Seidel master
at the 1 ms sampling step for ``case.duration_s``:

* plant: both flowrates held at the case's values (``q*_initial_ml_min = q*_final_ml_min``), started in
  the steady orbit of those flowrates, white noise of ``case.noise_um`` seeded from ``case.rng_seed``;
* estimator: the FMU's defaults (the recommended tuning, initial estimates the bearings' nominal flowrates, as
  the paper) with ``noise_um = case.noise_um``;
* the estimates after every step (t = dt ... T) are reduced by :func:`oilwatch.study.cases.reduce_record`.

A worker process loads the two FMUs once and reuses them for every case it runs (``fmi2Reset`` between
runs, see :class:`oilwatch.cosim.Master`). The FMUs' folder must be visible at the same path on every
worker (a local cluster, or a shared file system on a remote one).

The case's Cramer-Rao bound (:class:`ModelCrlb`) needs only the physics model, not the co-simulation.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from oilwatch.models.system.orbit_bound import cramer_rao_bound

from ..cosim.values import FMI2_INTEGER_RANGE
from .cases import CaseFailure, CaseResult, reduce_record
from .grid import SAMPLE_DT_S, Case

ML_MIN_TO_M3_S = 1.0 / 6.0e7

_SYSTEMS: dict[tuple, object] = {}
"""Per-process cache of full-order systems, so that a Dask worker builds the model once."""


def full_system(machine_file: str | None = None, table_path: str | None = None):
    """The full-order (all dofs) rotor-bearing system of a machine file, built once per process."""
    key = (machine_file, table_path)
    if key not in _SYSTEMS:
        from oilwatch.models.system.factory import load_system

        _SYSTEMS[key] = load_system(machine_file, reduced=False, table_path=table_path)
    return _SYSTEMS[key]


def case_crlb(system, case: Case) -> np.ndarray:
    """(2,) Cramer-Rao bound [ml/min] on the std of q1 and q2 for the case's record (all samples)."""
    flowrates = np.array([case.q1_ml_min, case.q2_ml_min]) * ML_MIN_TO_M3_S
    bound = cramer_rao_bound(system, flowrates, case.noise_um * 1e-6, case.n_samples, SAMPLE_DT_S)
    return bound.std_ml_min


@dataclass(frozen=True)
class ModelCrlb:
    """The model's Cramer-Rao bound as a case model's ``crlb`` callable: ``ModelCrlb()(case) -> (2,)``.

    ``system``: a rotor-bearing system to use; None loads the full-order model of ``machine_file`` (None:
    the bundled turbine) and its coefficient table (``table_path``, None: the default) once per process.
    """

    machine_file: str | None = None
    table_path: str | None = None
    system: object | None = None

    def __call__(self, case: Case) -> np.ndarray:
        machine_file = self.machine_file or case.machine_file or None
        system = self.system if self.system is not None else full_system(machine_file, self.table_path)
        return case_crlb(system, case)


_MASTERS: dict[str | None, object] = {}
"""Per-process masters with their two FMUs loaded, by FMU folder (None: the automatic build)."""
_RECORD = ["ekf.q1_est_ml_min", "ekf.q2_est_ml_min", "ekf.q1_std_ml_min", "ekf.q2_std_ml_min"]
FMI_SEED_MODULUS = FMI2_INTEGER_RANGE[1] + 1
"""The plant's ``seed`` is an FMI Integer (>= 0, 32 bits): the case's 63-bit seed is reduced modulo this."""


def _master(fmu_dir: str | None):
    """This process's master of the two FMUs of ``fmu_dir`` (None: the automatic build), loaded once."""
    from ..cosim import Master
    from ..scenarios.fmus import ensure_fmus, plant_and_estimator

    if fmu_dir not in _MASTERS:
        _MASTERS[fmu_dir] = Master(plant_and_estimator(ensure_fmus(fmu_dir), name="study"))
    return _MASTERS[fmu_dir]


def case_parameters(case: Case) -> dict[str, dict[str, object]]:
    """The FMU parameters of one case, by instance name (``plant``, ``ekf``)."""
    plant = {
        "q1_initial_ml_min": case.q1_ml_min,
        "q1_final_ml_min": case.q1_ml_min,
        "q2_initial_ml_min": case.q2_ml_min,
        "q2_final_ml_min": case.q2_ml_min,
        "noise_um": case.noise_um,
        "seed": case.rng_seed % FMI_SEED_MODULUS,
        "machine_file": case.machine_file,
    }
    ekf = {
        "noise_um": case.noise_um,
        "machine_file": case.machine_file,
        **{f"q{b}_initial_ml_min": q for b, q in enumerate(case.nominal_ml_min, start=1)},
        **{f"q{b}_nominal_ml_min": q for b, q in enumerate(case.nominal_ml_min, start=1)},
        "preset": "paper",  # the paper's Table 6 and Figs. 7-8: its calibrated filter
    }
    return {"plant": plant, "ekf": ekf}


def case_labels(case: Case) -> dict[str, dict[str, str]]:
    """How the user gave each FMU parameter of :func:`case_parameters` (``oilwatch study``'s flags, the
    grid point), so that an FMU error names what the user can change (``--seeds``, not ``plant.seed``)."""
    common = {"noise_um": "--noise-um", "machine_file": "--machine"}
    flows = {
        f"q{b}_{end}_ml_min": f"the study grid's q{b} = {pct:g} % of its nominal"
        for b, pct in ((1, case.q1_pct), (2, case.q2_pct))
        for end in ("initial", "final")
    }
    nominal = {
        f"q{b}_{kind}_ml_min": f"the nominal flowrate of bearing {b} of --machine"
        for b in (1, 2)
        for kind in ("initial", "nominal")
    }
    return {
        "plant": {**common, **flows, "seed": "--seeds"},
        "ekf": {
            **common,
            **nominal,
            "preset": "the study's estimator (the paper's calibrated filter)",
        },
    }


@dataclass(frozen=True)
class CosimCase:
    """The co-simulated case as a picklable callable: ``CosimCase(fmu_dir)(case) -> CaseResult``.

    fmu_dir: folder with RotorBearingPlant.fmu and OilFlowEKF.fmu (``python build.py --out DIR``); None:
    the automatic build of :func:`oilwatch.scenarios.fmus.ensure_fmus` (resolve it once, before a study,
    with :meth:`resolved`, so that workers do not build).
    """

    fmu_dir: str | None = None

    def resolved(self) -> CosimCase:
        """This case model with its FMU folder found (built when needed)."""
        from ..scenarios.fmus import ensure_fmus

        return CosimCase(str(ensure_fmus(self.fmu_dir).resolve()))

    def __call__(self, case: Case) -> CaseResult:
        from ..cosim import MemoryRecorder, SlaveError

        start = time.perf_counter()
        recorder = MemoryRecorder()
        master = _master(self.fmu_dir)
        try:
            master.run(
                stop_time=case.duration_s,
                step_size=SAMPLE_DT_S,
                start_time=0.0,
                order=["plant", "ekf"],
                record=_RECORD,
                recorder=recorder,
                parameters=case_parameters(case),
                labels=case_labels(case),
            )
        except SlaveError as error:
            # The instances are dead after an FMI error: the next case of this worker loads them anew.
            _MASTERS.pop(self.fmu_dir, None)
            master.close()
            raise CaseFailure(f"case {case.case_id} ({case.settings_text}): {error}") from None
        columns = recorder.arrays()
        estimates = np.column_stack([columns[name] for name in _RECORD[:2]])[1:]
        stds = np.column_stack([columns[name] for name in _RECORD[2:]])[1:]
        return reduce_record(case, columns["time"][1:], estimates, stds, time.perf_counter() - start)
