"""summary.json of ``oilwatch estimate``: the final estimates (over the last 10 % of the record, at most
30 s), each bearing's nominal flowrate (the reference of its percentages), the alarms, the verdict per
bearing, the record's provenance, the estimator's settings, the speed seen, where the time went, and per
probe its offset estimate and health at the end."""

from __future__ import annotations

import sys
from pathlib import Path

from oilwatch.estimator.ekf_config import ML_MIN
from oilwatch.estimator.nuisance_outputs import nuisance_names, nuisance_values

SPEED_MISMATCH_FRACTION = 0.01
"""A recorded speed this far from a model that does not follow it gets a warning."""


def final_window(duration_s: float) -> float:
    """The summary's final window: the last 10 % of the record, at most 30 s."""
    return min(0.1 * duration_s, 30.0)


def start_bank_summary(estimator) -> dict | None:
    """The start bank's starts, window and choice (None: one filter). A record that ends inside the window
    has no choice: its estimates are the nominal start's, as one filter's."""
    from oilwatch.estimator.start_bank import StartBank

    if not isinstance(estimator, StartBank):
        return None
    return {
        "start_fractions": list(estimator.fractions),
        "select_s": estimator.select_s,
        "chosen_start_fraction": estimator.chosen_fraction,
        "note": "the nominal start's estimates throughout: the record ended inside the selection window"
        if estimator.chosen is None
        else "the nominal start's estimates until the choice, the chosen start's after it",
    }


def summarize(run, wall_s: float, csv_path: Path) -> dict:
    """summary.json of a finished :class:`oilwatch.monitoring.estimate.EstimateRun` (module docstring)."""
    history = run.history
    history.flush()
    nominal = [q / ML_MIN for q in run.filter.config.q_nominal_pair()]
    duration = history.duration_s
    window = final_window(duration)
    final = history.final_means(window)
    summary = {
        "record": run.stream.provenance(),
        "machine_file": str(run.machine.source_path),
        "estimator": {
            "model": f"reduced rotor-bearing system of {run.machine.name!r}"
            + (
                " on the dimensionless bearing tables, following speed and oil temperature"
                if run.follow
                else f" at {run.speed_hz:g} Hz and the nominal viscosity"
            ),
            "operating_point": run.operating_reason,
            "dt_s": run.history.dt,
            "noise_um": run.setup.noise_um,
            "first_sample_time_s": run.filter.config.first_sample_time_s,
            "configuration": "EKFConfig.recommended: the OilFlowEKF FMU's defaults, with the machine "
            "file's probe offsets prior (FMU: offset_prior_std_um) or the baseline (FMU: baseline_file)",
            "offset_prior_std_um": round(run.filter.config.offset_prior_std_m * 1e6, 9),
            "probe_angle_deg": run.probe_angle_deg,
            "baseline_file": run.options.baseline_file,
            "baseline_age_days": run.baseline_age_days,  # None: unknown, the prior not widened by drift
            # each bearing's clearance over the file's, from the baseline's coast-down (None: the file's)
            "clearance_factors": None if run.clearance_factors is None else list(run.clearance_factors),
            "runout": run.runout_source,
            "start_bank": start_bank_summary(run.filter),
        },
        **{f"q{b}_nominal_ml_min": q for b, q in enumerate(nominal, start=1)},
        "samples": history.samples,
        "duration_s": duration,
        "final_window_s": window,
        **final,
        "alarms": history.alarms,
        "verdict": {},
        "speed": history.speed_summary(run.speed_hz),
        "wall_s": round(wall_s, 3),
        "estimator_s": round(run.estimator_s, 3),
        "stages_s": {name: round(value, 3) for name, value in run.stages_s.items()},
        "realtime_factor": round(duration / wall_s, 2) if wall_s > 0 else None,
        "cpu_s": round(run.cpu_s, 3),
        "realtime_factor_cpu": round(duration / run.cpu_s, 2) if run.cpu_s > 0 else None,
        "cpu_us_per_sample_by_tenth": run.cpu_marks.by_tenth_us(),
        "estimates_csv": str(csv_path),
    }
    summary["probes"] = _probe_summary(run)
    summary["model_mismatch"] = _mismatch_summary(history)
    if run.latency.count:
        summary["live_latency_ms"] = run.latency.summary_ms()
    for b in (1, 2):
        q = summary[f"q{b}_final_ml_min"]
        alarmed = any(a["bearing"] == b for a in history.alarms)
        starved_now = bool(history.last_starved[b - 1])
        summary["verdict"][f"bearing{b}"] = (
            "STARVED (alarm at the end)"
            if starved_now
            else "alarm raised during the record, cleared"
            if alarmed
            else "healthy"
        ) + ("" if q is None else f": {q:.1f} ml/min, {100.0 * q / nominal[b - 1]:.1f} % of nominal")
        summary["verdict"][f"bearing{b}"] += MISMATCH_VERDICT.get(history.last_mismatch, "")
    mismatch = summary["speed"].get("max_deviation_fraction")
    if not run.follow and mismatch is not None and mismatch > SPEED_MISMATCH_FRACTION:
        print(
            f"oilwatch estimate: warning: the recorded speed differs from the estimator's model "
            f"({run.speed_hz:g} Hz) by up to {100 * mismatch:.1f} % and the model does not follow it: "
            f"{run.operating_reason}",
            file=sys.stderr,
        )
    return summary


MISMATCH_VERDICT = {
    1: " (model mismatch: read from the static change relative to the baseline)",
    2: " (model mismatch: the estimate does not act, alarms held)",
}
"""What the verdict says of the model-mismatch status at the end of the record."""


def mismatch_reason(summary: dict) -> None:
    """A record that ends in a model mismatch (summary.json's ``model_mismatch``) is not trusted: its
    ``trust`` gets the reason (``oilwatch estimate`` then exits with
    :data:`oilwatch.monitoring.trust.UNTRUSTED_EXIT_CODE`)."""
    mismatch = summary.get("model_mismatch")
    if mismatch is None or mismatch["final"] == "consistent":
        return
    summary["trust"]["trusted"] = False
    summary["trust"]["reasons"].append(f"the record ends in a model mismatch ({mismatch['final']})")


def _mismatch_summary(history) -> dict | None:
    """The model-mismatch status at the end and the share of the record at each status (None: the estimator
    has none)."""
    from oilwatch.estimator.baseline_change import STATUS_NAMES

    if history.last_mismatch is None:
        return None
    total = max(1, int(history.mismatch_samples.sum()))
    return {
        "final": STATUS_NAMES[history.last_mismatch],
        "fraction": {
            name: round(int(n) / total, 6)
            for name, n in zip(STATUS_NAMES, history.mismatch_samples, strict=True)
        },
    }


def _probe_summary(run) -> dict:
    """Per probe at the end of the record: the estimator's offset estimate and std [um] (along the probe's
    axis when the estimator takes the readings so, ``oilwatch.estimator.probe_angle_deg``, else along x or y),
    its status, and the time it was flagged faulty."""
    from oilwatch.estimator.channels import STATUS_NAMES

    values = dict(zip((row[0] for row in nuisance_names()), nuisance_values(run.filter), strict=True))
    history = run.history
    out = {}
    for i, name in enumerate(("x1", "y1", "x2", "y2")):
        status = None if history.last_status is None else int(history.last_status[i])
        out[name] = {
            "offset_um": values[f"offset_{name}_um"],
            "offset_std_um": values[f"offset_{name}_std_um"],
            "status_final": None if status is None else STATUS_NAMES[status],
            "flagged_s": round(float(history.flagged_samples[i]) * history.dt, 6),
        }
    return out
