"""The robustness rows as the README's report: the Markdown table, the coverage line, and the rows' nuisance
Cramer-Rao bounds recomputed in each case's own configuration."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from oilwatch.models.machine import load_machine

from .bounds import configuration_label
from .case_run import case_bounds
from .cases import case_by_name


def with_case_bounds(rows: Sequence[dict], settings: dict) -> list[dict]:
    """The rows with ``bound_pct``, ``error_over_bound`` and ``bound_configuration`` computed afresh for
    each row's case in its own configuration (:mod:`.bounds`; rows of runs made before it held another)."""
    machine = load_machine(settings["machine_file"])
    bounds: dict = {}
    out = []
    for row in rows:
        if "error" in row:
            out.append(row)
            continue
        case = case_by_name(row["case"])
        bound = case_bounds(bounds, machine, settings, case).bound_pct(case, (row["q1_pct"], row["q2_pct"]))
        out.append(
            {
                **row,
                "bound_pct": bound.tolist(),
                "bound_configuration": configuration_label(case, settings),
                "error_over_bound": (np.abs(np.asarray(row["error_pct"])) / bound).tolist(),
            }
        )
    return out


def coverage_line(rows: Sequence[dict]) -> str:
    """How many rows have the truth within +-2 std at the end (the target is 90 % of the listed cases), and
    the model-structure cases' own count with their alarms."""
    from .cases import CASES

    listed = {case.name for case in CASES if case.listed}
    structural = {case.name for case in CASES if case.model_structure}
    run = [r for r in rows if "error" not in r]
    inside = [r for r in run if r["within_2_std"]]
    in_list = [r for r in run if r["case"] in listed]
    inside_list = [r for r in in_list if r["within_2_std"]]
    share = 100.0 * len(inside_list) / len(in_list) if in_list else math.nan
    line = (
        f"Truth within +-2 std at the end: {len(inside_list)} of {len(in_list)} rows of the acceptance cases "
        f"({share:.0f} %), {len(inside)} of {len(run)} with the extra cases."
    )
    structure_rows = [r for r in run if r["case"] in structural]
    if not in_list:
        line = f"Truth within +-2 std at the end: {len(inside)} of {len(run)} rows that ran."
    failed = [r for r in rows if "error" in r]
    structure_failed = [r for r in failed if r["case"] in structural]
    if structure_rows or structure_failed:
        total = len(structure_rows) + len(structure_failed)
        within = sum(r["within_2_std"] for r in structure_rows)
        tolerance = sum(r["within_tolerance"] for r in structure_rows)
        false_alarms = sum(r["false_alarm"] for r in structure_rows)
        low = [r for r in structure_rows if r["detected"]]
        detected = sum(all(r["detected"]) for r in low)
        line += (
            f" Model-structure cases, {total} rows ({len(structure_failed)} failed): truth within +-2 std in "
            f"{within}, error within 3 % (5 % all at once) in {tolerance}, a false alarm in {false_alarms}, "
            f"the 80 % bearing alarmed in {detected} of the {len(low)} that ran."
        )
    if failed:
        line += f" {len(failed)} rows failed (the reason in the row)."
    return line


def format_table(rows: Sequence[dict]) -> list[str]:
    """The rows as a Markdown table (errors and stds in % of the true flowrate, q1 / q2; consistent and
    mismatch: the shares of the second half with the NIS test passed and with a model-mismatch status, "-"
    in the rows of a file written before the rows kept the latter)."""
    lines = [
        "| case | truth % | error % | published std % | within tol. | within 2 std | false alarm "
        "| 80 % alarmed | flagged probes | consistent | mismatch | error / bound (bound %) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['case']} | {r['q1_pct']:g}/{r['q2_pct']:g} | FAILED: {r['error']} |")
            continue
        detected = "-" if not r["detected"] else ("yes" if all(r["detected"]) else "NO")
        flagged = ",".join(("x1", "y1", "x2", "y2")[c] for c in r["flagged_probes"]) or "-"
        error, std, ratio = r["error_pct"], r["std_pct"], r["error_over_bound"]
        false_alarm = "no"
        if r["false_alarm"]:
            false_alarm = "YES" + ("" if r["alarms_consistent"] else " (inconsistent)")
        name = r["case"]
        if r.get("estimator_follows_operating_point") is False:
            name += " *"
        cells = [
            name,
            f"{r['q1_pct']:g}/{r['q2_pct']:g}",
            f"{error[0]:+.2f} / {error[1]:+.2f}",
            f"{std[0]:.2f} / {std[1]:.2f}",
            "yes" if r["within_tolerance"] else "NO",
            "yes" if r["within_2_std"] else "NO",
            false_alarm,
            detected,
            flagged,
            f"{r['consistent_fraction']:.2f}",
            "-" if r.get("mismatch_fraction") is None else f"{r['mismatch_fraction']:.2f}",
            f"{ratio[0]:.1f} / {ratio[1]:.1f}"
            + (f" ({r['bound_pct'][0]:.2f} / {r['bound_pct'][1]:.2f})" if "bound_pct" in r else ""),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", coverage_line(rows)]
    if any(r.get("estimator_follows_operating_point") is False for r in rows):
        lines.append("")
        lines.append("\\* the estimator does not follow the measured speed, temperature or viscosity yet.")
    return lines
