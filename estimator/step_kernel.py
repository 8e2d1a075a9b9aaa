"""The whole filter step after the model's transition in one compiled call: update, summary, alarm.

:func:`sample_step` runs :func:`oilwatch.estimator.kernels.filter_step` (predict, screen, gate, Joseph update,
projection), then what :mod:`oilwatch.estimator.ekf` reports of the sample (:func:`step_summary`: the windowed
NIS test, the convergence rule, the SI estimates and the nuisances' estimates and stds), the unbalance's
process noise of the next prediction (wider while the model is inconsistent) and the starvation alarm
(:func:`oilwatch.estimator.alarm.update_alarm`). Everything the step reports lands in one float array laid out
by the ``REPORT_*`` slices below, so that the per-sample Python work is one call and one copy, and a batch of
samples (:meth:`oilwatch.estimator.ekf.OilFlowEKF.run_batch`) stores a row per sample. For a model on a
flowrate grid at one speed (``GridAugmentedModel.batch_transition``) :func:`grid_batch` runs a whole record in
one call: the grid's compiled transition, then :func:`sample_step`, sample after sample; for the operating
model (``OperatingAugmentedModel.compiled_transition``) :func:`operating_step` runs one sample's transitions
and :func:`sample_step` in one call, back to Python only when the correction's centre must move first. They
take the filter's arrays as one :class:`oilwatch.estimator.filter_arrays.FilterArrays`; :func:`ekf_step` is
the one-sample entry from Python after a transition evaluated there.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from oilwatch.models.system.flowrate_grid import interpolate_map
from oilwatch.models.system.operating_kernels import (
    RECENTRE,
    operating_transition,
)

from .alarm import RAISED_CONSISTENT, STARVED, hold_alarm, update_alarm
from .baseline_change import CHANGE_ACTION, CONSISTENT, MISMATCH_BASELINE, update_change
from .channels import STATUS
from .filter_arrays import FilterArrays
from .kernels import UPDATE_ACCEPTED, filter_step


def _layout(*fields: tuple[str, int]) -> tuple[dict[str, int], int]:
    """The start of each ``(name, width)`` field laid end to end, and the total size."""
    starts, size = {}, 0
    for name, width in fields:
        starts[name] = size
        size += width
    return starts, size


# the report array (REPORT_SIZE,): the published flowrates [m^3/s] and their stds (the filter's own while
# the model is consistent, else as estimator.baseline_change says), the viscosity factors and stds (1 and 0
# if not estimated), offsets [m] and stds, unbalance and stds (0 if not estimated), the sample's scalars and
# flags as floats (per bearing, or per probe for the status), the model-mismatch status, the filter's own
# flowrates (each clipped to its bearing's table) and stds, and the baseline-relative static estimate and
# std (NaN when no static reference applies)
_REPORT, REPORT_SIZE = _layout(
    ("flowrate", 2),
    ("std", 2),
    ("viscosity", 2),
    ("viscosity_std", 2),
    ("offset", 4),
    ("offset_std", 4),
    ("unbalance", 2),
    ("unbalance_std", 2),
    ("nis", 1),
    ("rows", 1),
    ("ok", 1),
    ("converged", 1),
    ("consistent", 1),
    ("starved", 2),
    ("starved_consistent", 2),
    ("changing", 2),
    ("status", 4),
    ("mismatch", 1),
    ("filter_flowrate", 2),
    ("filter_std", 2),
    ("baseline_flowrate", 2),
    ("baseline_std", 2),
)
REPORT_FLOWRATE, REPORT_STD = _REPORT["flowrate"], _REPORT["std"]
REPORT_VISCOSITY, REPORT_VISCOSITY_STD = _REPORT["viscosity"], _REPORT["viscosity_std"]
REPORT_OFFSET, REPORT_OFFSET_STD = _REPORT["offset"], _REPORT["offset_std"]
REPORT_UNBALANCE, REPORT_UNBALANCE_STD = _REPORT["unbalance"], _REPORT["unbalance_std"]
REPORT_NIS, REPORT_ROWS, REPORT_OK = _REPORT["nis"], _REPORT["rows"], _REPORT["ok"]
REPORT_CONVERGED, REPORT_CONSISTENT = _REPORT["converged"], _REPORT["consistent"]
REPORT_STARVED, REPORT_STARVED_CONSISTENT = _REPORT["starved"], _REPORT["starved_consistent"]
REPORT_CHANGING, REPORT_STATUS = _REPORT["changing"], _REPORT["status"]
REPORT_MISMATCH = _REPORT["mismatch"]
REPORT_FILTER_FLOWRATE, REPORT_FILTER_STD = _REPORT["filter_flowrate"], _REPORT["filter_std"]
REPORT_BASELINE_FLOWRATE, REPORT_BASELINE_STD = _REPORT["baseline_flowrate"], _REPORT["baseline_std"]
# the int64 counters array: advanced in place (step, since_update) and the state's layout
_COUNTERS, N_COUNTERS = _layout(
    ("step", 1), ("since_update", 1), ("first", 1), ("viscosity", 1), ("unbalance", 1), ("offsets", 1)
)
COUNT_STEP, COUNT_SINCE_UPDATE = _COUNTERS["step"], _COUNTERS["since_update"]
COUNT_FIRST, COUNT_VISCOSITY = _COUNTERS["first"], _COUNTERS["viscosity"]
COUNT_UNBALANCE, COUNT_OFFSETS = _COUNTERS["unbalance"], _COUNTERS["offsets"]
# the settings array of :func:`step_summary` and :func:`ekf_step`
_SUMMARY, N_SUMMARY_SETTINGS = _layout(
    ("q_nominal", 2),  # each bearing's nominal flowrate, the filter's flowrate unit [m^3/s]
    ("q_bounds", 4),  # each bearing's flowrate range (low1, high1, low2, high2) [m^3/s]
    ("consistency_z", 1),
    ("converged_std", 1),
    ("converged_drift", 1),
    ("unbalance_walk", 1),
    ("unbalance_extra", 1),
    ("std_floor", 2),  # the alarm's floor on each flowrate std [m^3/s] (0: none)
    ("held_std", 2),  # each flowrate's prior std, around its nominal, for a held mismatch [m^3/s]
)
SUMMARY_Q_NOMINAL, SUMMARY_Q_BOUNDS = _SUMMARY["q_nominal"], _SUMMARY["q_bounds"]
SUMMARY_CONSISTENCY_Z, SUMMARY_CONVERGED_STD = _SUMMARY["consistency_z"], _SUMMARY["converged_std"]
SUMMARY_CONVERGED_DRIFT, SUMMARY_UNBALANCE_WALK = _SUMMARY["converged_drift"], _SUMMARY["unbalance_walk"]
SUMMARY_UNBALANCE_EXTRA, SUMMARY_STD_FLOOR = _SUMMARY["unbalance_extra"], _SUMMARY["std_floor"]
SUMMARY_HELD_STD = _SUMMARY["held_std"]


@njit(cache=True)
def _nuisance(state, covariance, first, count, out, out_std, absent):
    for b in range(count):
        if first >= 0:
            out[b] = state[first + b]
            out_std[b] = np.sqrt(covariance[first + b, first + b])
        else:
            out[b] = absent[b]
            out_std[b] = 0.0


@njit(cache=True)
def step_summary(
    state: np.ndarray,
    covariance: np.ndarray,
    counters: np.ndarray,
    nis: float,
    rows: int,
    nis_window: np.ndarray,
    nis_sums: np.ndarray,
    history: np.ndarray,
    settings: np.ndarray,
    report: np.ndarray,
) -> tuple[bool, bool]:
    """What the filter reports after the update of sample ``counters[COUNT_STEP]``, in place: the windowed
    NIS test and the convergence rule of :mod:`oilwatch.estimator.ekf`, and the SI estimates.

    counters : COUNT_* (the state's layout: index of q1 / its nominal, first viscosity factor, unbalance and
    offset, -1 when not estimated; since_update: samples since the last accepted update, this one
    included). nis, rows : of this sample (0 when it made no update). nis_window (C, 2), nis_sums (2,),
    history (W, 2) : the ring buffers, advanced here. settings : the SUMMARY_* values. report : the
    REPORT_* estimates written (the filter's flowrates, each clipped to its bearing's table [m^3/s], stds,
    nuisances: their known values and std 0 when not estimated). Returns ``(model_consistent, converged)``.
    """
    step = counters[COUNT_STEP]
    first = counters[COUNT_FIRST]
    slot = step % nis_window.shape[0]
    nis_sums[0] += nis - nis_window[slot, 0]
    nis_sums[1] += rows - nis_window[slot, 1]
    nis_window[slot, 0] = nis
    nis_window[slot, 1] = rows
    dof = nis_sums[1]
    consistent = True
    if not (step + 1 < nis_window.shape[0] or dof < 1.0):
        # Wilson-Hilferty: chi2 quantile ~ dof (1 - 2/(9 dof) + z sqrt(2/(9 dof)))^3
        c = 2.0 / (9.0 * dof)
        consistent = nis_sums[0] <= dof * (1.0 - c + settings[SUMMARY_CONSISTENCY_Z] * np.sqrt(c)) ** 3.0
    window = history.shape[0]
    slot = step % window
    drift = 0.0
    largest = 0.0
    for b in range(2):
        scaled = state[first + b]
        deviation = np.sqrt(covariance[first + b, first + b])
        drift = max(drift, abs(scaled - history[slot, b]))
        history[slot, b] = scaled
        largest = max(largest, deviation)
        # clipped in SI as well: the round trip through the scaled unit may leave a bound by one ulp
        low, high = settings[SUMMARY_Q_BOUNDS + 2 * b], settings[SUMMARY_Q_BOUNDS + 2 * b + 1]
        scale = settings[SUMMARY_Q_NOMINAL + b]
        report[REPORT_FILTER_FLOWRATE + b] = min(max(scaled * scale, low), high)
        report[REPORT_FILTER_STD + b] = deviation * scale
    ones = np.ones(2)
    zeros = np.zeros(4)
    unit = np.array([1.0, 0.0])  # the machine file's unbalance
    _nuisance(
        state,
        covariance,
        counters[COUNT_VISCOSITY],
        2,
        report[REPORT_VISCOSITY : REPORT_VISCOSITY + 2],
        report[REPORT_VISCOSITY_STD : REPORT_VISCOSITY_STD + 2],
        ones,
    )
    _nuisance(
        state,
        covariance,
        counters[COUNT_OFFSETS],
        4,
        report[REPORT_OFFSET : REPORT_OFFSET + 4],
        report[REPORT_OFFSET_STD : REPORT_OFFSET_STD + 4],
        zeros,
    )
    _nuisance(
        state,
        covariance,
        counters[COUNT_UNBALANCE],
        2,
        report[REPORT_UNBALANCE : REPORT_UNBALANCE + 2],
        report[REPORT_UNBALANCE_STD : REPORT_UNBALANCE_STD + 2],
        unit,
    )
    converged = (
        step >= window
        and counters[COUNT_SINCE_UPDATE] < window
        and largest < settings[SUMMARY_CONVERGED_STD]
        and drift < settings[SUMMARY_CONVERGED_DRIFT]
    )
    return consistent, converged


@njit(cache=True)
def ekf_step(
    predict: bool,
    next_state: np.ndarray,
    state_jacobian: np.ndarray,
    flowrate_jacobian: np.ndarray,
    displacement: np.ndarray,
    packed: tuple,
) -> None:
    """:func:`sample_step` on ``packed``, the filter's arrays as ``tuple(FilterArrays)``: the entry from
    Python (a plain tuple dispatches faster than the NamedTuple: :mod:`oilwatch.estimator.filter_arrays`)."""
    sample_step(FilterArrays(*packed), predict, next_state, state_jacobian, flowrate_jacobian, displacement)


# inlined into its two callers: called with the struct by value it cost 1.5 us per sample more (measured)
@njit(cache=True, inline="always")
def sample_step(
    a: FilterArrays,
    predict: bool,
    next_state: np.ndarray,
    state_jacobian: np.ndarray,
    flowrate_jacobian: np.ndarray,
    displacement: np.ndarray,
) -> None:
    """One sample after the model's transition (module docstring), in place on the filter's arrays ``a``;
    advances ``a.counters[COUNT_STEP]`` and ``a.counters[COUNT_SINCE_UPDATE]``. The other arguments are the
    sample's: the transition (``next_state`` and its Jacobians, see
    :func:`oilwatch.estimator.kernels.filter_step`, whose flowrate scale is
    ``a.summary_settings[SUMMARY_Q_NOMINAL : SUMMARY_Q_NOMINAL + 2]``, each bearing's nominal) and the
    measured displacements; ``a.report`` (REPORT_SIZE,) out."""
    summary_settings, counters, report = a.summary_settings, a.counters, a.report
    process_noise, changing, health = a.process_noise, a.changing, a.health
    alarm_record = a.alarm_record
    status, nis, rows, _ = filter_step(
        a,
        predict,
        next_state,
        state_jacobian,
        flowrate_jacobian,
        summary_settings[SUMMARY_Q_NOMINAL : SUMMARY_Q_NOMINAL + 2],
        displacement,
    )
    ok = status == UPDATE_ACCEPTED
    if not (ok and np.isfinite(nis)):
        nis, rows = 0.0, 0
    counters[COUNT_SINCE_UPDATE] = 0 if ok else counters[COUNT_SINCE_UPDATE] + 1
    consistent, converged = step_summary(
        a.state,
        a.covariance,
        counters,
        nis,
        rows,
        a.nis_window,
        a.nis_sums,
        a.history,
        summary_settings,
        report,
    )
    unbalance = counters[COUNT_UNBALANCE]
    if unbalance >= 0:
        variance = summary_settings[SUMMARY_UNBALANCE_WALK]
        if not consistent:
            variance += summary_settings[SUMMARY_UNBALANCE_EXTRA]
        process_noise[unbalance, unbalance] = variance
        process_noise[unbalance + 1, unbalance + 1] = variance
    # the alarm judges the filter's flowrates with their std floored (estimator.nuisance_start.
    # InformationFloor, set by the filter; 0 otherwise) while the model is consistent, the baseline-relative
    # static estimate during a mismatch when there is one, and nothing otherwise (estimator.baseline_change)
    change = a.change
    status = update_change(
        change,
        displacement,
        health,
        consistent,
        report[REPORT_FILTER_FLOWRATE : REPORT_FILTER_FLOWRATE + 2],
        report[REPORT_FILTER_STD : REPORT_FILTER_STD + 2],
        report[REPORT_BASELINE_FLOWRATE : REPORT_BASELINE_FLOWRATE + 2],
        report[REPORT_BASELINE_STD : REPORT_BASELINE_STD + 2],
    )
    act = change[CHANGE_ACTION] != 0.0 and status != CONSISTENT
    # with the mismatch action, an alarm waits for a tested model: until the NIS window has filled once the
    # consistency test has nothing to say (a start-up transient read a healthy bearing as starved for 2 s)
    untested = change[CHANGE_ACTION] != 0.0 and counters[COUNT_STEP] + 1 < a.nis_window.shape[0]
    # nor on an estimate the NIS test already rejects while the mismatch status waits for its hold
    untested = untested or (change[CHANGE_ACTION] != 0.0 and status == CONSISTENT and not consistent)
    # the report keeps the filter's own std (the filter floors it itself)
    for b in range(2):
        report[REPORT_FLOWRATE + b] = report[REPORT_FILTER_FLOWRATE + b]
        report[REPORT_STD + b] = max(report[REPORT_FILTER_STD + b], summary_settings[SUMMARY_STD_FLOOR + b])
    if act and status == MISMATCH_BASELINE:
        for b in range(2):
            flow = report[REPORT_BASELINE_FLOWRATE + b]
            flow = max(flow, summary_settings[SUMMARY_Q_BOUNDS + 2 * b])
            report[REPORT_FLOWRATE + b] = min(flow, summary_settings[SUMMARY_Q_BOUNDS + 2 * b + 1])
            own = report[REPORT_BASELINE_STD + b]
            report[REPORT_STD + b] = own
            if consistent:
                # the mismatch rests on the two estimates' disagreement alone, and the data do not say
                # which part of the model is wrong (a film model moves the 1x orbit, a clearance the static
                # curve): the published std covers the filter's estimate too
                gap = report[REPORT_FILTER_FLOWRATE + b] - report[REPORT_BASELINE_FLOWRATE + b]
                excess = max(0.0, gap * gap - report[REPORT_FILTER_STD + b] ** 2)
                report[REPORT_STD + b] = np.sqrt(own * own + excess)
    if (act and status != MISMATCH_BASELINE) or untested:
        hold_alarm(alarm_record)
    else:
        update_alarm(
            report[REPORT_FLOWRATE : REPORT_FLOWRATE + 2],
            report[REPORT_STD : REPORT_STD + 2],
            consistent,
            alarm_record,
            a.alarm_settings,
        )
    if act and status != MISMATCH_BASELINE:
        # the filter's estimate, with the flowrate known no better than before the record: the model that
        # narrowed its std does not explain the data, and the NIS excess alone (its std times sqrt(NIS / dof)
        # over the window) is no measure of how far a model error has moved it. With the truth distributed
        # as the prior (nominal, its std), the estimate's RMS error is sqrt(std^2 + (estimate - nominal)^2)
        excess = np.sqrt(max(1.0, a.nis_sums[0] / max(a.nis_sums[1], 1.0)))
        for b in range(2):
            prior = summary_settings[SUMMARY_HELD_STD + b]
            widened = report[REPORT_FILTER_STD + b] * excess
            moved = report[REPORT_FILTER_FLOWRATE + b] - summary_settings[SUMMARY_Q_NOMINAL + b]
            report[REPORT_STD + b] = max(widened, np.sqrt(prior * prior + moved * moved))
    elif not act:
        for b in range(2):
            own = report[REPORT_FILTER_STD + b]
            report[REPORT_STD + b] = own
            static = report[REPORT_BASELINE_FLOWRATE + b]
            if change[CHANGE_ACTION] != 0.0 and np.isfinite(static):
                # what the static change says the filter misses beyond its own noise widens its std: a
                # disagreement under the mismatch test's threshold is still error the filter cannot explain
                gap = report[REPORT_FILTER_FLOWRATE + b] - static
                excess = max(0.0, gap * gap - report[REPORT_BASELINE_STD + b] ** 2)
                report[REPORT_STD + b] = np.sqrt(own * own + excess)
    report[REPORT_MISMATCH] = status
    report[REPORT_NIS] = nis
    report[REPORT_ROWS] = rows
    report[REPORT_OK] = 1.0 if ok else 0.0
    report[REPORT_CONVERGED] = 1.0 if converged else 0.0
    report[REPORT_CONSISTENT] = 1.0 if consistent else 0.0
    for b in range(2):
        starved = alarm_record[STARVED, b] != 0
        report[REPORT_STARVED + b] = 1.0 if starved else 0.0
        both = starved and alarm_record[RAISED_CONSISTENT, b] != 0
        report[REPORT_STARVED_CONSISTENT + b] = 1.0 if both else 0.0
        report[REPORT_CHANGING + b] = 1.0 if changing[b] else 0.0
    for i in range(4):
        report[REPORT_STATUS + i] = health[i, STATUS]
    counters[COUNT_STEP] += 1


@njit(cache=True)
def grid_batch(
    grid_transition: np.ndarray,
    grid_forcing: np.ndarray,
    axes: np.ndarray,
    omega_rad_s: float,
    dt_s: float,
    first_step: int,
    record: np.ndarray,
    table: np.ndarray,
    next_state: np.ndarray,
    state_jacobian: np.ndarray,
    flowrate_jacobian: np.ndarray,
    exogenous: np.ndarray,
    packed: tuple,
) -> None:
    """:func:`sample_step` for every sample of ``record`` (K, 4), each report into ``table[k]``, with the grid
    model's transition (:func:`oilwatch.models.system.flowrate_grid.interpolate_map` from the current estimate
    at ``w = [1, cos(Omega t), sin(Omega t)]``, ``t = (first_step + k - 1) dt``, as
    ``GridAugmentedModel.transition``) before every sample but the filter's first. ``packed``: the
    filter's arrays as ``tuple(FilterArrays)``."""
    a = FilterArrays(*packed)
    state, counters, report = a.state, a.counters, a.report
    n = next_state.shape[0]
    for k in range(record.shape[0]):
        predict = counters[COUNT_STEP] > 0
        if predict:
            time_s = (first_step + counters[COUNT_STEP] - 1) * dt_s
            phase = omega_rad_s * time_s
            exogenous[0] = 1.0
            exogenous[1] = np.cos(phase)
            exogenous[2] = np.sin(phase)
            q1, q2 = report[REPORT_FILTER_FLOWRATE], report[REPORT_FILTER_FLOWRATE + 1]
            next_, jacobian, flow = next_state, state_jacobian, flowrate_jacobian
            interpolate_map(
                grid_transition, grid_forcing, axes, state[:n], exogenous, q1, q2, next_, jacobian, flow
            )
        sample_step(a, predict, next_state, state_jacobian, flowrate_jacobian, record[k])
        table[k, :] = report


DECLINED = -2
""":func:`operating_step`'s answer for a sample it leaves to the Python path (nothing changed): flowrates off
the model's grid or a viscosity factor that is not positive, which the model's Python entry reports."""


@njit(cache=True)
def operating_step(
    model_arrays: tuple,
    exogenous: np.ndarray,
    limits: np.ndarray,
    phase: float,
    model_step: int,
    factor_range: np.ndarray,
    shadow: np.ndarray,
    predicted: np.ndarray,
    settling: bool,
    no_flow_jacobian: np.ndarray,
    displacement: np.ndarray,
    packed: tuple,
) -> int:
    """One predicted sample on the operating model in one call, as :meth:`oilwatch.estimator.ekf.OilFlowEKF.
    step` predicts with the model's Python entry: the transition
    (:func:`oilwatch.models.system.operating_kernels.operating_transition` on the struct ``model_arrays``
    with its ``exogenous`` work array, ``limits`` the grid's flowrate range, at the rotor angle ``phase``
    of the transition from ``model_step``), then :func:`sample_step` on ``packed`` (the filter's arrays as
    ``tuple(FilterArrays)``) and the viscosity factors clipped to ``factor_range`` (2,).

    The flowrates are the report's filter flowrates, the factors the state's clipped to ``factor_range`` and
    the unbalance the state's (those the counters say are estimated). ``shadow`` (n,) or (0,): the shadow
    state of :class:`oilwatch.estimator.nuisance_start.ShadowJacobian`, advanced in place; the transition
    is then the shadow's, whose flowrate and nuisance Jacobians the update takes, and the estimate's
    prediction at the same point only its next state, into ``predicted`` (n,) (``second_state`` of
    :func:`oilwatch.models.system.operating_kernels.operating_transition`: the state Jacobian is the same
    at every state). ``settling``: the parameters out of the Jacobian (``no_flow_jacobian``, zero nuisance
    columns). Returns the transition's answer (``GRID_ONLY`` or ``CORRECTED``), or ``RECENTRE`` or
    :data:`DECLINED` with nothing changed: the centre must move first (then call again), or the sample is
    the Python path's."""
    a = FilterArrays(*packed)
    state, counters, report, trailing = a.state, a.counters, a.report, a.trailing_jacobian
    q1, q2 = report[REPORT_FILTER_FLOWRATE], report[REPORT_FILTER_FLOWRATE + 1]
    if not (limits[0] <= q1 <= limits[1] and limits[2] <= q2 <= limits[3]):
        return DECLINED
    viscosity, unbalance = counters[COUNT_VISCOSITY], counters[COUNT_UNBALANCE]
    with_factors = viscosity >= 0
    f1 = f2 = 1.0
    if with_factors:
        f1 = _clipped(state[viscosity], factor_range)
        f2 = _clipped(state[viscosity + 1], factor_range)
        if not (f1 > 0.0 and f2 > 0.0):
            return DECLINED
    u = state[unbalance : unbalance + 2] if unbalance >= 0 else state[:0]
    nxt, state_jacobian, flow_jacobian = model_arrays[8], model_arrays[9], model_arrays[10]
    viscosity_jacobian, unbalance_jacobian = model_arrays[11], model_arrays[12]
    n = nxt.shape[0]
    shadowed = shadow.shape[0] > 0
    if shadowed:
        # the estimate's prediction at the same point in the same pass: the shadow's A_d, its next state alone
        answer = operating_transition(
            model_arrays, shadow, exogenous, phase, u, q1, q2, f1, f2, with_factors, model_step,
            state[:n], predicted,
        )  # fmt: skip
        if answer == RECENTRE:
            return RECENTRE
        shadow[:] = nxt
        nxt = predicted
    else:
        answer = operating_transition(
            model_arrays, state[:n], exogenous, phase, u, q1, q2, f1, f2, with_factors, model_step
        )
        if answer == RECENTRE:
            return RECENTRE
    parameters = flow_jacobian
    if settling:
        parameters = no_flow_jacobian
        trailing[:, :] = 0.0
    else:
        _nuisance_columns(trailing, with_factors, unbalance >= 0, viscosity_jacobian, unbalance_jacobian)
    sample_step(a, True, nxt, state_jacobian, parameters, displacement)
    if with_factors:  # P left unchanged, as at the flowrates' bounds
        state[viscosity] = _clipped(state[viscosity], factor_range)
        state[viscosity + 1] = _clipped(state[viscosity + 1], factor_range)
    return answer


@njit(cache=True, inline="always")
def _clipped(value, bounds):
    """``value`` within ``bounds`` (2,) as ``np.clip`` (a NaN stays NaN)."""
    if value < bounds[0]:
        return bounds[0]
    if value > bounds[1]:
        return bounds[1]
    return value


@njit(cache=True)
def _nuisance_columns(trailing, with_factors, with_unbalance, viscosity_jacobian, unbalance_jacobian):
    """The transition's nuisance columns into ``trailing``: the viscosity factors' first, the unbalance's
    after them."""
    first = 0
    if with_factors:
        trailing[:, :2] = viscosity_jacobian
        first = 2
    if with_unbalance:
        trailing[:, first : first + 2] = unbalance_jacobian
