"""The study's physics-side pieces for the co-simulated case: the model's Cramer-Rao bound per case.

Where the real case goes: the co-simulated case is a module-level function here,
``run_cosim_case(case: Case) -> CaseResult``, which runs the plant FMU and the EKF FMU through the master
(``oilwatch.cosim.Master``) for ``case.duration_s`` with the case's flowrates, ``case.noise_um`` and the
noise seed ``case.rng_seed``, records time, the two flowrate estimates and their stds, and returns
``reduce_record(case, times, estimates, stds, wall_s)``. Plugging it in is the one line in
``oilwatch/study/registry.py``::

    "cosim": CaseModel(run_cosim_case, ModelCrlb(), "plant FMU + EKF FMU through the fmpy master"),

after which ``oilwatch study`` (default ``--case cosim``) and ``benchmarks/study_scaling.py --case cosim``
use it. The bound below needs only the physics model, not the co-simulation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.system.identifiability import cramer_rao_bound

from .grid import NOMINAL_Q_ML_MIN, SAMPLE_DT_S, Case

ML_MIN_TO_M3_S = 1.0 / 6.0e7

_SYSTEMS: dict[tuple, object] = {}
"""Per-process cache of full-order systems, so that a Dask worker builds the model once."""


def full_system(machine_file: str | None = None, table_path: str | None = None):
    """The full-order (all dofs) rotor-bearing system of a machine file, built once per process."""
    key = (machine_file, table_path)
    if key not in _SYSTEMS:
        from models.system.factory import load_system

        _SYSTEMS[key] = load_system(machine_file, reduced=False, table_path=table_path)
    return _SYSTEMS[key]


def case_crlb(system, case: Case) -> np.ndarray:
    """(2,) Cramer-Rao bound [ml/min] on the std of q1 and q2 for the case's record (all samples)."""
    flowrates = np.array([case.q1_pct, case.q2_pct]) / 100.0 * NOMINAL_Q_ML_MIN * ML_MIN_TO_M3_S
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
        system = self.system if self.system is not None else full_system(self.machine_file, self.table_path)
        return case_crlb(system, case)
