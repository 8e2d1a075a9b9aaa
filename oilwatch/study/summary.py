"""Aggregate the study's cases into Table 6's figures, beside the paper's and the accuracy targets.

Aggregation (the paper's, Sec. 3.2.1): for each noise level, the absolute relative errors
``|q_est - q_true| / q_true`` of BOTH bearings in ALL cases (and seeds) form one set of 2 x n_cases values;
``mean_err_pct``, ``std_err_pct`` (sample std, ddof = 1) and ``max_err_pct`` are taken over that set.
``mean_err_pct_b1`` / ``_b2`` are the means per bearing (the paper quotes 2.28 % and 1.37 % at 1 um).

Cramer-Rao ratio: for each bearing, the RMS over the cases of the error normalized by the case's bound,
``sqrt(mean(((q_est - q_true) / crlb)^2))``; ``mean_crlb_ratio`` is the mean of the two bearings' ratios.
It is 1 for an unbiased estimator that attains the bound, and says how much room the estimator has left.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .grid import Case

AGGREGATION = (
    "per noise level, over both bearings and all cases (and seeds): |relative error| = "
    "|q_est - q_true| / q_true in %, the paper's Table 6 aggregation; mean, sample std (ddof=1), max. "
    "crlb ratio per bearing: RMS over cases of (q_est - q_true) / CRLB std; mean_crlb_ratio: mean of the "
    "two bearings (1 = an unbiased estimator attaining the bound)"
)

PAPER_TABLE6 = {
    1.0: {
        "mean_err_pct": 1.82,
        "std_err_pct": 0.99,
        "max_err_pct": 5.06,
        "mean_err_pct_b1": 2.28,
        "mean_err_pct_b2": 1.37,
    },
    2.0: {"mean_err_pct": 3.54, "std_err_pct": 1.97, "max_err_pct": 9.93},
}
"""Table 6 of the paper (per-bearing means from the text of Sec. 3.2.1, given only at 1 um)."""

TARGETS = {
    1.0: {"mean_err_pct": 0.9, "max_err_pct": 2.5},
    2.0: {"mean_err_pct": 1.8, "max_err_pct": 5.0},
}
"""The accuracy targets (upper limits), which beat the paper's Table 6."""


def _stats(rows: list[dict]) -> dict:
    """Error statistics of a non-empty set of case rows."""
    errors = np.array([[row["q1_err_pct"], row["q2_err_pct"]] for row in rows])
    absolute = np.abs(errors)
    flat = absolute.ravel()
    case_index, bearing = np.unravel_index(int(np.argmax(absolute)), absolute.shape)
    worst = rows[case_index]
    result = {
        "mean_err_pct": float(flat.mean()),
        "std_err_pct": float(flat.std(ddof=1)) if flat.size > 1 else 0.0,
        "max_err_pct": float(flat.max()),
        "worst_case": {
            "case_id": worst["case_id"],
            "q1_pct": worst["q1_pct"],
            "q2_pct": worst["q2_pct"],
            "seed": worst["seed"],
            "bearing": int(bearing) + 1,
            "err_pct": float(errors[case_index, bearing]),
        },
        "mean_err_pct_b1": float(absolute[:, 0].mean()),
        "mean_err_pct_b2": float(absolute[:, 1].mean()),
        "rms_err_pct": float(np.sqrt(np.mean(flat**2))),
        "bias_pct_b1": float(errors[:, 0].mean()),
        "bias_pct_b2": float(errors[:, 1].mean()),
    }
    # the filter's own confidence: its std in % of the truth, and how often the truth lies within +-2 std
    truth = np.array([[row["q1_true_ml_min"], row["q2_true_ml_min"]] for row in rows])
    std_pct = 100.0 * np.array([[row["q1_std_ml_min"], row["q2_std_ml_min"]] for row in rows]) / truth
    result.update(
        mean_std_pct=float(std_pct.mean()), within_2std_fraction=float(np.mean(absolute <= 2 * std_pct))
    )
    bounds = np.array([[row["crlb_q1_ml_min"], row["crlb_q2_ml_min"]] for row in rows])
    if np.all(np.isfinite(bounds)) and np.all(bounds > 0.0):
        truth = np.array([[row["q1_true_ml_min"], row["q2_true_ml_min"]] for row in rows])
        estimate = np.array([[row["q1_est_ml_min"], row["q2_est_ml_min"]] for row in rows])
        ratio = np.sqrt(np.mean(((estimate - truth) / bounds) ** 2, axis=0))
        result.update(
            mean_crlb_ratio=float(ratio.mean()),
            crlb_ratio_b1=float(ratio[0]),
            crlb_ratio_b2=float(ratio[1]),
            mean_crlb_pct=float(np.mean(100.0 * bounds / truth)),
        )
    else:
        result.update(mean_crlb_ratio=None, crlb_ratio_b1=None, crlb_ratio_b2=None, mean_crlb_pct=None)
    return result


def _targets(noise_um: float, stats: dict | None) -> dict | None:
    target = TARGETS.get(noise_um)
    if target is None:
        return None
    if stats is None:
        return {**target, "pass_mean": None, "pass_max": None, "pass": None}
    pass_mean = stats["mean_err_pct"] <= target["mean_err_pct"]
    pass_max = stats["max_err_pct"] <= target["max_err_pct"]
    return {**target, "pass_mean": pass_mean, "pass_max": pass_max, "pass": pass_mean and pass_max}


def noise_level_summary(rows: Sequence[dict], noise_um: float, n_expected: int) -> dict:
    """Table 6 figures of one noise level from its case rows (any order), with the paper and the targets."""
    ordered = sorted(rows, key=lambda row: row["case_id"])
    stats = _stats(ordered) if ordered else None
    keys = ("mean_err_pct", "std_err_pct", "max_err_pct", "worst_case", "mean_crlb_ratio", "mean_std_pct",
            "within_2std_fraction")  # fmt: skip
    summary = {"noise_um": noise_um, "n_cases": len(ordered), "n_expected": n_expected}
    summary["complete"] = len(ordered) == n_expected
    summary.update({key: None for key in keys} if stats is None else stats)
    summary["paper"] = PAPER_TABLE6.get(noise_um)
    summary["target"] = _targets(noise_um, stats)
    return summary


def summarize(rows: dict[str, dict], cases: Sequence[Case], failed: Sequence[dict], settings: dict) -> dict:
    """The study's ``summary.json`` content.

    rows: finished case rows by case id (rows of cases outside ``cases`` are ignored). failed: the cases
    that kept failing in this run, ``{"case_id", "error"}``. settings: the study's settings.
    """
    levels = []
    for noise in sorted({case.noise_um for case in cases}):
        level_ids = [case.case_id for case in cases if case.noise_um == noise]
        level_rows = [rows[case_id] for case_id in level_ids if case_id in rows]
        levels.append(noise_level_summary(level_rows, noise, len(level_ids)))
    return {
        "settings": settings,
        "aggregation": AGGREGATION,
        "noise_levels": levels,
        "failed_cases": sorted(failed, key=lambda item: item["case_id"]),
        "complete": all(level["complete"] for level in levels),
    }
