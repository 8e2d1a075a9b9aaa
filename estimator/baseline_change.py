"""The model-mismatch status and the flowrates read from the static change relative to a commissioning
baseline.

Why: the filter's flowrate leans on the 1x orbit once the probe offsets are uncertain, and the 1x orbit is
what a real machine's model gets wrong (the film model, supports, runout, unbalance distribution). When the
windowed NIS test (``model_consistent``) says the data are not what the model predicts, the filter's estimate
and its std cannot be taken at face value. The static journal position is far less sensitive to those model
errors, and relative to a commissioning record at known flowrates (same machine, same probes) its change
measures the flowrate change with the model's static curve alone.

Status (:data:`CONSISTENT`, :data:`MISMATCH_BASELINE`, :data:`MISMATCH_HELD`):

* the evidence of a mismatch is ``model_consistent`` false, or (with a static reference) the filter's
  flowrate and the static estimate further apart than :data:`DISAGREEMENT_Z` times their combined std:
  two estimates that rest on different parts of the model (the 1x orbit, the static position) disagree by
  more than their noise only through the model's error, and a film model the free nuisances absorb leaves
  the NIS consistent (a quasi-static plant read by the synchronous model: -7 % at nominal, NIS consistent);
* the status turns to a mismatch when the NIS test's evidence has added up to :data:`MISMATCH_HOLD_ON_S`
  (each sample without it taking :data:`MISMATCH_EVIDENCE_LEAK` of a sample off: bursts that recur count,
  a rare one does not), or the disagreement has lasted that long at a stretch, and back when the NIS
  test's evidence has leaked away and there has been no evidence for :data:`MISMATCH_HOLD_OFF_S`, or
  :data:`MISMATCH_BASELINE_HOLD_OFF_S` while the baseline's static reference applies (hysteresis: an
  intermittent test does not chatter, and bursts that recur more often than the leak keep the status);
* while it is a mismatch and the baseline's static reference applies (:data:`MISMATCH_BASELINE`), the
  published flowrates and stds are the baseline-relative static estimate's and the starvation alarm
  judges them; when the NIS test is passed (the mismatch is the two estimates' disagreement alone) the
  published std also covers the filter's estimate, since the data do not say which part of the model is
  wrong (a film model moves the 1x orbit, a bearing clearance off by its tolerance the static curve);
* while it is a mismatch and no static reference applies (:data:`MISMATCH_HELD`: no baseline, a baseline
  without its static reference, another operating point, too few samples yet) the published flowrates are
  the filter's, their std what it would be were the flowrate known no better than before the record: the
  estimate's RMS error with the truth distributed as the prior, ``sqrt(s0^2 + (q - q_nominal)^2)``
  (``s0`` the flowrates' prior std ``initial_flowrate_std_m3_s``, a quarter of nominal; no less than the
  filter's std widened by the NIS excess, ``sqrt(NIS / dof)`` over the consistency window), and the alarm
  neither sets nor clears: an inconsistent estimate never acts on its own. The model that narrowed the
  filter's std does not explain the data, and the NIS excess does not measure how far a model error moved
  the estimate (the compressor's probes all 5 % off their scale factor, no baseline: +18 % on bearing 2,
  the std widened by the NIS excess 0.8 %; the turbine's runout uncompensated, no baseline: -54 %);
* with the action on, the alarm also neither sets nor clears before the NIS window has filled once (an
  untested model is not a consistent one), nor while the NIS test fails and the status waits for its hold.

Static estimate: a fading-memory mean (time constant :data:`STATIC_WINDOW_S`) of each probe's signal
(after any runout compensation), minus the baseline record's mean, is the change of the journal's static
position since the baseline (the offsets and the zero-mean 1x and 2x parts cancel). Each bearing's flowrate is
the point of the model's static curve (its probe pair's static signal against that bearing's flowrate, the
other at its baseline value; :func:`static_curves`) nearest to that change. Its std combines the baseline's
and the drift's offset uncertainty, the mean's noise and what of the change lies off the curve (something
other than the flowrate moved the journal), each divided by the curve's slope there, and a fraction
:data:`STATIC_MODEL_FRACTION` of the change itself (the static model's own error on the change).

Everything sits in one float array (:func:`new_change_array`, ``CHANGE_*`` layout) that the compiled step
advances (:func:`update_change`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

MISMATCH_HOLD_ON_S = 0.5
"""The status turns to a mismatch after its evidence has added up to this long (half the NIS window: a test
that fails once in a while, as a 1e-3 tail does, does not turn it)."""
MISMATCH_EVIDENCE_LEAK = 0.02
"""The NIS test's evidence adds up over bursts: each sample that fails the test counts one, each that passes
takes this off the count (never below zero, never above the hold-on's), so the status turns once the
failures outweigh a fraction 0.02 of the time without them. The test's own tail (1e-3) stays far below; a
model-structure mismatch fails it in short bursts more often than that (a quasi-static plant read by the
synchronous model: 7.7 % of the samples in 118 bursts over 60 s, half of them under 5 ms; the compressor's
probes all 5 % off without a baseline: 4.7 % in 123 bursts, the longest 0.4 s, while bearing 2 read +18 %
with a 0.8 % std). The disagreement between the filter and the static estimate is not added up this way:
both are smoothed over about a second and the static estimate's std carries a guessed model fraction
(:data:`STATIC_MODEL_FRACTION`), so its exceedances have no calibrated tail to leak against (added up, a
bearing 5 % longer than the model's at 80/90 % read +3.07 % instead of +2.94 %, the static curve being the
wrong part there). The status returns only once the count has leaked back to zero (after a count at the
hold-on, 25 s without failures): with the hold-off alone, those compressor probes' bursts, up to several
seconds apart, turned it back between them, and at the record's end it was consistent, its std 0.8 %."""
MISMATCH_HOLD_OFF_S = 5.0
"""...and back after no evidence for this long (and the NIS test's count leaked away): a mismatch comes and
goes with the machine's state, and an estimate that flips between sources every second is no estimate.
Without a static reference the status holds the alarm, so this stays short: a real starvation's alarm waits
for it."""
MISMATCH_BASELINE_HOLD_OFF_S = 15.0
"""...and this long while the baseline's static reference applies. A model-structure mismatch is persistent,
but the windowed NIS test sees it in bursts: a plant on the quasi-static film read by the synchronous model
(80/90 % of nominal) failed the test in 118 bursts over 60 s, 7 % of the samples, with gaps of up to 7 s
between them, so a 5 s hold-off returned to the filter's estimate (+6.5 % on the 80 % bearing, std 1.3 %)
between bursts and the published flowrate alternated with the static estimate's (-0.1 %, std 2.5 %). Staying
on the static estimate costs little (it is an honest estimate, and the alarm acts on it); twice the longest
gap measured."""
DISAGREEMENT_Z = 3.0
"""The filter's flowrate further than this many combined stds from the static estimate is evidence of a
mismatch (0.3 % of pairs of honest estimates by chance, per bearing and sample)."""
STATIC_WINDOW_S = 1.0
"""Time constant of the probes' fading-memory mean [s]: 75 revolutions at the turbine's speed, so the 1x and
2x parts leave under 1e-3 of their amplitude and the 1 um noise 0.02 um."""
STATIC_MODEL_FRACTION = 0.1
"""The static model's relative error on the change since the baseline: a film 5 % more viscous than the oil
law moves the static curve by about 14 % (100 -> 80 % of nominal: -4.39 um against -5.09 um)."""
CONSISTENT, MISMATCH_BASELINE, MISMATCH_HELD = 0, 1, 2
"""The ``model_mismatch`` status codes."""
STATUS_NAMES = ("consistent", "mismatch-baseline-change", "mismatch-held")

# settings
(
    CHANGE_ACTION,
    CHANGE_HOLD_ON,
    CHANGE_HOLD_OFF,
    CHANGE_AVAILABLE,
    CHANGE_WEIGHT,
    CHANGE_MIN_SAMPLES,
    CHANGE_FLOOR_M,
    CHANGE_MODEL_FRACTION,
    CHANGE_Q0,  # 2: the baseline's flowrates [m^3/s]
) = (0, 1, 2, 3, 4, 5, 6, 7, 8)
CHANGE_REFERENCE = 10  # 4: the baseline record's mean probe signals [m]
CHANGE_APPLIES = 14  # 1: the reference applies at the current operating point (:func:`reference_applies`)
CHANGE_DISAGREEMENT = 15  # z of the disagreement test (0: off)
CHANGE_BASELINE_HOLD_OFF = 16  # the hold-off while the reference applies [samples]
CHANGE_EVIDENCE_LEAK = 17  # what a sample without evidence takes off the evidence count
# state
CHANGE_STATUS, CHANGE_ON_COUNT, CHANGE_OFF_COUNT = 18, 19, 20  # ON: the NIS test's evidence, added up
CHANGE_DISAGREE_COUNT = 21  # samples the filter and the static estimate have disagreed in a row
CHANGE_MEAN = 22  # 4: the fading-memory mean of each probe [m]
CHANGE_SAMPLES = 26  # 4: samples in each mean
CHANGE_POINTS = 30  # the curves' number of points G
CHANGE_CURVES = 31  # per bearing: flowrates (G) [m^3/s], then the probe pair's static change (G each) [m]
CURVE_POINTS = 41
"""Points of each bearing's static curve over its coefficient table's flowrate range."""
CHANGE_SIZE = CHANGE_CURVES + 2 * 3 * CURVE_POINTS
SPEED_TOLERANCE_FRACTION = 0.005
TEMPERATURE_TOLERANCE_C = 1.0
"""The baseline's static reference applies within these of the baseline record's mean speed and oil
temperature: the static position moves with both (the model's static curve is the baseline point's)."""


def static_curves(model, probe_rotation: np.ndarray, q0_m3_s, points: int = CURVE_POINTS) -> np.ndarray:
    """(2, 3, points): per bearing b, the flowrates over its table's range and the probe pair's static signal
    at each (the other bearing at its ``q0_m3_s``) minus the signal at ``q0_m3_s`` [m], from the model's
    static equilibrium (its film at the oil law's viscosity) and the probes' mounting (``probe_rotation``).

    Not at the baseline's viscosity factors: a baseline reads them from the 1x orbit, which is what the
    model gets wrong (with 2 um of runout a 1.05 film read 0.97 / 0.91; a quasi-static plant read by the
    synchronous model gave factors that moved the 80 % reading by -9 %), while a film a few % more viscous
    than the oil law moves the static curve by about a seventh per 5 % (100 -> 80 % of nominal: -5.09 um at
    1, -4.39 um at 1.05): :data:`STATIC_MODEL_FRACTION` covers that."""
    observe = probe_rotation @ np.asarray(model.output_matrix, dtype=float)
    q0 = np.asarray(q0_m3_s, dtype=float)
    origin = observe @ model.static_state(q0)
    curves = np.zeros((2, 3, points))
    for b, (low, high) in enumerate(model.bearing_flowrate_bounds_m3_s):
        grid = np.linspace(low, high, points)
        curves[b, 0] = grid
        for k, value in enumerate(grid):
            q = q0.copy()
            q[b] = value
            signal = observe @ model.static_state(q) - origin
            curves[b, 1:, k] = signal[2 * b : 2 * b + 2]
    return curves


def new_change_array(config, model, dt_s: float, probe_rotation: np.ndarray) -> np.ndarray:
    """The change array (``CHANGE_*`` layout) of a configuration: the settings, the baseline's static
    reference when ``config.offset_baseline`` has one (``CHANGE_AVAILABLE`` 0 otherwise) and the curves."""
    change = np.zeros(CHANGE_SIZE)
    change[CHANGE_ACTION] = 1.0 if config.model_mismatch_action else 0.0
    change[CHANGE_HOLD_ON] = max(1, round(MISMATCH_HOLD_ON_S / dt_s))
    change[CHANGE_HOLD_OFF] = max(1, round(MISMATCH_HOLD_OFF_S / dt_s))
    change[CHANGE_BASELINE_HOLD_OFF] = max(1, round(MISMATCH_BASELINE_HOLD_OFF_S / dt_s))
    change[CHANGE_EVIDENCE_LEAK] = MISMATCH_EVIDENCE_LEAK
    weight = min(1.0, dt_s / STATIC_WINDOW_S)
    change[CHANGE_WEIGHT] = weight
    change[CHANGE_MIN_SAMPLES] = max(1, round(STATIC_WINDOW_S / dt_s))
    change[CHANGE_MODEL_FRACTION] = STATIC_MODEL_FRACTION
    change[CHANGE_DISAGREEMENT] = DISAGREEMENT_Z
    change[CHANGE_POINTS] = CURVE_POINTS
    baseline = config.offset_baseline
    reference = None if baseline is None else baseline.static_reference_m
    if reference is None or not config.model_mismatch_action:
        return change
    q0 = np.asarray(baseline.flowrates_m3_s, dtype=float)
    change[CHANGE_AVAILABLE] = change[CHANGE_APPLIES] = 1.0
    change[CHANGE_Q0 : CHANGE_Q0 + 2] = q0
    change[CHANGE_REFERENCE : CHANGE_REFERENCE + 4] = reference
    # the offsets' uncertainty since the baseline (its fit and the drift its age allows) and the noise left
    # in the fading mean (variance sigma^2 a / (2 - a) for weight a)
    offsets = float(np.max(baseline.offset_prior_std_m()))
    noise = config.noise_std_m * math.sqrt(weight / (2.0 - weight))
    change[CHANGE_FLOOR_M] = math.hypot(offsets, noise)
    curves = static_curves(model, probe_rotation, q0)
    change[CHANGE_CURVES:] = curves.ravel()
    return change


def reset_change(change: np.ndarray) -> None:
    """Back to a consistent status and empty means (settings, reference and curves kept)."""
    change[CHANGE_STATUS : CHANGE_SAMPLES + 4] = 0.0
    change[CHANGE_APPLIES] = change[CHANGE_AVAILABLE]


def reference_applies(
    change: np.ndarray, baseline, speed_hz: float | None, temperature_c: float | None
) -> None:
    """Whether the baseline's static reference applies at the measured operating point: within
    :data:`SPEED_TOLERANCE_FRACTION` and :data:`TEMPERATURE_TOLERANCE_C` of the baseline record's own (a
    point the baseline did not record is taken as its)."""
    if change[CHANGE_AVAILABLE] == 0.0:
        return
    applies = True
    reference = baseline.static_reference_speed_hz
    if speed_hz is not None and reference is not None:
        applies = abs(speed_hz - reference) <= SPEED_TOLERANCE_FRACTION * reference
    reference = baseline.static_reference_temperature_c
    if temperature_c is not None and reference is not None:
        applies = applies and abs(temperature_c - reference) <= TEMPERATURE_TOLERANCE_C
    change[CHANGE_APPLIES] = 1.0 if applies else 0.0


@njit(cache=True)
def _nearest_on_curve(change, b, d0, d1):
    """(flowrate, slope [m per m^3/s], distance off the curve [m]) of the point of bearing b's static curve
    nearest to the change (d0, d1)."""
    g = int(change[CHANGE_POINTS])
    base = CHANGE_CURVES + b * 3 * g
    best, flow, slope = np.inf, change[base], 0.0
    for k in range(g - 1):
        qa, qb = change[base + k], change[base + k + 1]
        a0, a1 = change[base + g + k], change[base + 2 * g + k]
        b0, b1 = change[base + g + k + 1], change[base + 2 * g + k + 1]
        e0, e1 = b0 - a0, b1 - a1
        length2 = e0 * e0 + e1 * e1
        t = 0.0
        if length2 > 0.0:
            t = min(1.0, max(0.0, ((d0 - a0) * e0 + (d1 - a1) * e1) / length2))
        p0, p1 = a0 + t * e0 - d0, a1 + t * e1 - d1
        distance = p0 * p0 + p1 * p1
        if distance < best:
            best = distance
            flow = qa + t * (qb - qa)
            slope = np.sqrt(length2) / (qb - qa)
    return flow, slope, np.sqrt(best)


@njit(cache=True)
def update_change(
    change, displacement, health, consistent, filter_flow, filter_std, out_flow, out_std
) -> int:
    """Advance the static means and the status by one sample (module docstring), in place on ``change``;
    ``health`` the probes' records (status in column 0, 0 healthy), ``filter_flow`` / ``filter_std`` (2,)
    the filter's estimates and stds [m^3/s]. Writes the static estimate into ``out_flow`` / ``out_std`` (2,)
    [m^3/s] when the reference applies (NaN otherwise) and returns the status."""
    out_flow[:] = np.nan
    out_std[:] = np.nan
    available = change[CHANGE_APPLIES] != 0.0
    if available:
        weight = change[CHANGE_WEIGHT]
        for i in range(4):
            value = displacement[i]
            if np.isfinite(value) and health[i, 0] == 0:
                count = change[CHANGE_SAMPLES + i] + 1.0
                change[CHANGE_SAMPLES + i] = count
                w = max(weight, 1.0 / count)
                change[CHANGE_MEAN + i] += w * (value - change[CHANGE_MEAN + i])
            available = available and change[CHANGE_SAMPLES + i] >= change[CHANGE_MIN_SAMPLES]
    disagree = False
    if available:
        floor = change[CHANGE_FLOOR_M]
        fraction = change[CHANGE_MODEL_FRACTION]
        z = change[CHANGE_DISAGREEMENT]
        for b in range(2):
            d0 = change[CHANGE_MEAN + 2 * b] - change[CHANGE_REFERENCE + 2 * b]
            d1 = change[CHANGE_MEAN + 2 * b + 1] - change[CHANGE_REFERENCE + 2 * b + 1]
            flow, slope, off = _nearest_on_curve(change, b, d0, d1)
            spread = np.sqrt(floor * floor + off * off) / max(slope, 1e-300)
            model = fraction * abs(flow - change[CHANGE_Q0 + b])
            out_flow[b] = flow
            out_std[b] = np.sqrt(spread * spread + model * model)
            gap = abs(filter_flow[b] - flow)
            disagree = disagree or (z > 0.0 and gap > z * np.sqrt(out_std[b] ** 2 + filter_std[b] ** 2))
    hold_on = change[CHANGE_HOLD_ON]
    if consistent:
        change[CHANGE_ON_COUNT] = max(0.0, change[CHANGE_ON_COUNT] - change[CHANGE_EVIDENCE_LEAK])
    else:
        change[CHANGE_ON_COUNT] = min(hold_on, change[CHANGE_ON_COUNT] + 1.0)
    change[CHANGE_DISAGREE_COUNT] = change[CHANGE_DISAGREE_COUNT] + 1.0 if disagree else 0.0
    if consistent and not disagree:
        change[CHANGE_OFF_COUNT] += 1.0
        hold_off = change[CHANGE_BASELINE_HOLD_OFF] if available else change[CHANGE_HOLD_OFF]
        settled = change[CHANGE_OFF_COUNT] >= hold_off and change[CHANGE_ON_COUNT] == 0.0
        if change[CHANGE_STATUS] != CONSISTENT and settled:
            change[CHANGE_STATUS] = CONSISTENT
    else:
        change[CHANGE_OFF_COUNT] = 0.0
        evidence = max(change[CHANGE_ON_COUNT], change[CHANGE_DISAGREE_COUNT])
        if change[CHANGE_STATUS] == CONSISTENT and evidence >= hold_on:
            change[CHANGE_STATUS] = MISMATCH_HELD
    if change[CHANGE_STATUS] != CONSISTENT:
        change[CHANGE_STATUS] = MISMATCH_BASELINE if available else MISMATCH_HELD
    return int(change[CHANGE_STATUS])
