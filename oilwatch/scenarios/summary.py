"""Figures of merit of a scenario run, from its recorded columns (the ``result.csv`` columns).

* ``qN_err_pct_before``: mean over the samples of ``|q_est - q_true| / q_true`` (in %) in the window
  ``[transition_start_s - 2 s, transition_start_s)``; null when the window does not fit in the record.
* ``qN_err_pct_after``: the same over the last 2 s of the record, ``(duration - 2 s, duration]``.
* ``alarm_delay_s_bN``: time of the first sample at or after ``transition_start_s`` with the bearing's
  starvation alarm on, minus the sigmoid's centre ``fault_time_s`` (negative: the alarm came before the
  centre, as it can during a slow drop); null when the alarm never comes, as it must for a bearing that
  does not starve.
* ``false_alarm_s_bN``: time of the first alarm before ``transition_start_s`` (null: none).
* ``first_alarm_s_bN``: time of the first alarm of the record (null: none). For a bearing starved from the
  start (``constant`` below 90 % of nominal) this is its detection time, and the two figures above are
  null: an alarm there is neither late nor false.
* ``qN_settle_s``: time after the centre from which the estimate stays within 2 % of the truth to the end
  of the record (0: it never left; null: it is still outside at the end). The after-drop error alone hides
  a slow convergence.
"""

from __future__ import annotations

import math

import numpy as np

from . import WINDOW_S, ScenarioRun

SETTLE_TOLERANCE = 0.02
"""Relative band [1] of the settling time (2 %, the demo's after-drop criterion)."""


def window_error_pct(
    time_s: np.ndarray, q_true: np.ndarray, q_est: np.ndarray, start_s: float, stop_s: float
) -> float | None:
    """Mean relative error [%] of ``q_est`` against ``q_true`` (shape (n,)) for ``start_s <= t < stop_s``
    (``stop_s`` included when it is the last sample). None when the window starts before the record or
    holds no sample."""
    if start_s < time_s[0] - 1e-9:
        return None
    last = stop_s >= time_s[-1] - 1e-9
    inside = (time_s >= start_s - 1e-9) & ((time_s <= stop_s + 1e-9) if last else (time_s < stop_s - 1e-9))
    if not inside.any():
        return None
    return float(np.mean(np.abs(q_est[inside] - q_true[inside]) / q_true[inside]) * 100.0)


def first_alarm_s(
    time_s: np.ndarray, alarm: np.ndarray, start_s: float, stop_s: float = math.inf
) -> float | None:
    """Time [s] of the first sample in ``[start_s, stop_s)`` with ``alarm`` on (nonzero), or None."""
    window = (time_s >= start_s - 1e-9) & (time_s < stop_s - 1e-9) & (alarm != 0)
    return float(time_s[np.argmax(window)]) if window.any() else None


def settle_time_s(
    time_s: np.ndarray,
    q_true: np.ndarray,
    q_est: np.ndarray,
    centre_s: float,
    tolerance: float = SETTLE_TOLERANCE,
) -> float | None:
    """Time [s] after ``centre_s`` from which ``|q_est - q_true| <= tolerance q_true`` holds to the end of
    the record; 0 when it always holds after the centre, None when it fails at the last sample."""
    after = time_s >= centre_s - 1e-9
    outside = after & (np.abs(q_est - q_true) > tolerance * q_true)
    if not outside.any():
        return 0.0
    last = int(np.flatnonzero(outside)[-1])
    if last == len(time_s) - 1:
        return None
    return float(time_s[last + 1] - centre_s)


def summarize(run: ScenarioRun, columns: dict[str, np.ndarray]) -> dict:
    """Figures of merit (module docstring) from ``columns`` (result.csv names, each shape (n,))."""
    time_s = columns["time_s"]
    end = float(time_s[-1])
    start = run.transition_start_s
    summary: dict[str, object] = {}
    for b in (1, 2):
        true, estimate = columns[f"q{b}_true_ml_min"], columns[f"q{b}_est_ml_min"]
        summary[f"q{b}_err_pct_before"] = window_error_pct(time_s, true, estimate, start - WINDOW_S, start)
        summary[f"q{b}_err_pct_after"] = (
            window_error_pct(time_s, true, estimate, end - WINDOW_S, end)
            if end >= run.duration_s - 1e-9
            else None
        )
        summary[f"q{b}_settle_s"] = settle_time_s(time_s, true, estimate, run.fault_time_s)
    for b in (1, 2):
        alarm = columns[f"starved{b}"]
        summary[f"first_alarm_s_b{b}"] = first_alarm_s(time_s, alarm, -math.inf)
        summary[f"starved_initially_b{b}"] = run.starved_initially(b)
        if run.starved_initially(b):
            summary[f"alarm_delay_s_b{b}"] = summary[f"false_alarm_s_b{b}"] = None
        else:
            at = first_alarm_s(time_s, alarm, start)
            summary[f"alarm_delay_s_b{b}"] = None if at is None else round(at - run.fault_time_s, 6)
            summary[f"false_alarm_s_b{b}"] = first_alarm_s(time_s, alarm, -math.inf, start)
        summary[f"starving_b{b}"] = run.starving(b)
    return summary
