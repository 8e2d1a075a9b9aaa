"""The case models a study can run, by name (``oilwatch study --case NAME``).

``cosim`` (the default: the plant FMU and the EKF FMU through the master), ``direct`` (the same plant model
and EKF in-process, without FMI; a cross-check of the FMU path), ``direct-nuisances`` (the same with the
machine's nuisances unknown estimator states) and ``synthetic`` (machinery tests).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from oilwatch.models.validation import InputError

from .case_cosim import CosimCase, ModelCrlb
from .case_direct import run_direct_case, run_direct_case_nuisances_unknown
from .cases import CaseResult, SyntheticCase
from .grid import Case

DEFAULT_CASE = "cosim"


@dataclass(frozen=True)
class CaseModel:
    """A case function and, optionally, the Cramer-Rao bound that goes with it.

    run_case: ``(Case) -> CaseResult``, picklable (it runs on Dask workers).
    crlb: ``(Case) -> (2,)`` bound on the std of q1, q2 [ml/min], or None.
    """

    run_case: Callable[[Case], CaseResult]
    crlb: Callable[[Case], np.ndarray] | None = None
    description: str = ""


_SYNTHETIC = SyntheticCase()

CASE_MODELS: dict[str, CaseModel] = {
    "cosim": CaseModel(
        CosimCase(),
        ModelCrlb(),
        "plant FMU (full model) and EKF FMU (reduced grid model) through oilwatch's fmpy master",
    ),
    "direct": CaseModel(
        run_direct_case,
        ModelCrlb(),
        "plant model (full, Newmark) and EKF (reduced grid model) in-process, without FMI",
    ),
    "direct-nuisances": CaseModel(
        run_direct_case_nuisances_unknown,
        ModelCrlb(),
        "as direct, with the probe offsets and the complex unbalance unknown estimator states (the "
        "machine file's [probes] prior; the plant has none): the price of not knowing them",
    ),
    "synthetic": CaseModel(
        _SYNTHETIC,
        _SYNTHETIC.crlb,
        "synthetic estimate records (tests the study machinery; not oilwatch's estimator)",
    ),
}


def get_case_model(name: str, fmu_dir: str | None = None) -> CaseModel:
    """The registered case model called ``name``; an InputError lists the available ones.

    For ``cosim`` the FMUs are found here, once (``fmu_dir``, or built automatically), so that the workers
    load them without building; ``fmu_dir`` applies to ``cosim`` only.
    """
    if name not in CASE_MODELS:
        available = ", ".join(sorted(CASE_MODELS))
        raise InputError(f"--case {name!r} is not available; available: {available}")
    if fmu_dir is not None and name != "cosim":
        raise InputError(f"--fmu-dir applies to --case cosim only, not --case {name}")
    model = CASE_MODELS[name]
    if name == "cosim":
        return replace(model, run_case=CosimCase(fmu_dir).resolved())
    return model
