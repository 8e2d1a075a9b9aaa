"""The identification-accuracy study (the paper's Sec. 3.2.1, Table 6, Figs. 7-8) on Dask.

from oilwatch.study import make_cases, run_study, get_case_model

cases = make_cases(noise_um=[1.0, 2.0], grid_step_pct=1.0)
outcome = run_study(cases, "study_out", get_case_model("synthetic"), "synthetic")
outcome.summary["noise_levels"][0]["mean_err_pct"]
"""

from .cases import CaseFailure, CaseResult, SyntheticCase, reduce_record
from .grid import Case, bundled_nominal_ml_min, grid_percents, make_cases
from .registry import CASE_MODELS, CaseModel, get_case_model
from .runner import StudyOutcome, dask_client, run_study

__all__ = [
    "CASE_MODELS",
    "Case",
    "CaseFailure",
    "CaseModel",
    "CaseResult",
    "StudyOutcome",
    "SyntheticCase",
    "bundled_nominal_ml_min",
    "dask_client",
    "get_case_model",
    "grid_percents",
    "make_cases",
    "reduce_record",
    "run_study",
]
