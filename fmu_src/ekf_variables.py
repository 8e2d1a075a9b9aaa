"""The estimator FMU's variables: its own parameters, the per-step inputs and outputs and their order in the
fast path's arrays, and their declarations (names, units, ranges, descriptions: the one source of the FMU's
modelDescription and of the README's variable table, ``python -m oilwatch.cosim.fmu_docs``).

The step's outputs are written with one numpy division of the step report's columns (:data:`REPORT_COLUMNS`,
:data:`REPORT_DIVISORS`), on the Python path (:mod:`oilwatch.fmu_src.oilwatch_ekf_slave`) and in the compiled
plain step (:mod:`oilwatch.fmu_src.ekf_plain_step`) alike.
"""

from __future__ import annotations

import numpy as np

from oilwatch.estimator.baseline_change import STATUS_NAMES as MISMATCH_NAMES
from oilwatch.estimator.boundary_parameters import ESTIMATOR_PARAMETERS
from oilwatch.estimator.channels import STATUS_NAMES
from oilwatch.estimator.ekf_config import (
    DEFAULT_PRESET,
    ML_MIN,
    PRESETS,
    RECOMMENDED_DISPLACEMENT_PROCESS_STD_M,
)
from oilwatch.estimator.nuisance_outputs import nuisance_names
from oilwatch.estimator.step_kernel import (
    REPORT_CONSISTENT,
    REPORT_CONVERGED,
    REPORT_FLOWRATE,
    REPORT_MISMATCH,
    REPORT_NIS,
    REPORT_OK,
    REPORT_ROWS,
    REPORT_STARVED,
    REPORT_STATUS,
    REPORT_STD,
)
from oilwatch.fmu_src.ekf_start_outputs import SETTLED_OUTPUT, START_OUTPUTS, declare_start_outputs
from oilwatch.fmu_src.machine_parameters import declare_machine_parameters
from oilwatch.models.validation import MAX_AGE_DAYS, MAX_FLOWRATE_ML_MIN, MAX_PROBE_UM

SAMPLING_PERIOD_S = 1e-3
POSITIONS = ("x1", "y1", "x2", "y2")
GRID_TOLERANCE = 1e-3
"""A sample time within this fraction of a period of the grid is on the grid."""
KEYPHASOR_UNCONNECTED = -1.0
STEP_INPUTS = (
    *(f"{name}_um" for name in POSITIONS),
    "t_sample_s",
    "rotor_angle_deg",
    "speed_hz",
    "oil_temperature_c",
)
"""The inputs read by every step (the fast path's input array, in this order)."""
REPORT_OUTPUTS = (
    ("q1_est_ml_min", REPORT_FLOWRATE, ML_MIN),
    ("q2_est_ml_min", REPORT_FLOWRATE + 1, ML_MIN),
    ("q1_std_ml_min", REPORT_STD, ML_MIN),
    ("q2_std_ml_min", REPORT_STD + 1, ML_MIN),
    ("nis", REPORT_NIS, 1.0),
    ("n_channels", REPORT_ROWS, 1.0),
    ("converged", REPORT_CONVERGED, 1.0),
    ("starved1", REPORT_STARVED, 1.0),
    ("starved2", REPORT_STARVED + 1, 1.0),
    ("measurement_ok", REPORT_OK, 1.0),
    ("model_consistent", REPORT_CONSISTENT, 1.0),
    *((f"probe_status_{name}", REPORT_STATUS + i, 1.0) for i, name in enumerate(POSITIONS)),
    ("model_mismatch", REPORT_MISMATCH, 1.0),
    (SETTLED_OUTPUT.name, REPORT_CONVERGED, 1.0),  # cleared during the starts (fmu_src.ekf_start_outputs)
)
"""The outputs taken from the step report: name, report column (``oilwatch.estimator.step_kernel`` REPORT_*
layout), divisor (SI -> field units; flags and counts as 0/1 and whole numbers)."""
STEP_OUTPUTS = (
    *(name for name, _, _ in REPORT_OUTPUTS),
    "t_estimate_s",
    *(output.name for output in START_OUTPUTS),
)
"""The outputs published with every step (the fast path's output array, in this order)."""
T_ESTIMATE_INDEX = STEP_OUTPUTS.index("t_estimate_s")
SETTLED_INDEX = STEP_OUTPUTS.index(SETTLED_OUTPUT.name)
START_CHOOSING_INDEX = STEP_OUTPUTS.index("start_choosing")
START_SETTLING_INDEX = STEP_OUTPUTS.index("settling_start_left_s")
"""Nonzero while a start is under way (the slave's step then writes the start outputs)."""
START_SLICE = slice(T_ESTIMATE_INDEX + 1, T_ESTIMATE_INDEX + 1 + len(START_OUTPUTS))
"""Where :data:`oilwatch.fmu_src.ekf_start_outputs.START_OUTPUTS` lie in the output array."""
REPORT_COLUMNS = np.array([column for _, column, _ in REPORT_OUTPUTS])
REPORT_DIVISORS = np.array([divisor for _, _, divisor in REPORT_OUTPUTS])
OWN_REALS = (
    ("sample_period_s", SAMPLING_PERIOD_S, "s", 1e-5, 0.01,
     "Sampling period of the filter's discrete model; its samples lie on t = k period"),
    *((f"q{b}_initial_ml_min", 0.0, "ml/min", 0.0, MAX_FLOWRATE_ML_MIN,
       f"Initial flowrate estimate of bearing {b} (within its coefficient table range); 0: its nominal "
       f"(q{b}_nominal_ml_min)") for b in (1, 2)),
    *((f"q{b}_nominal_ml_min", 0.0, "ml/min", 0.0, MAX_FLOWRATE_ML_MIN,
       f"Nominal flowrate of bearing {b}: the reference of its alarm levels and of its estimate's start and "
       f"scaling; 0: the machine file's nominal flowrate of bearing {b}") for b in (1, 2)),
    ("baseline_age_days", 0.0, "d", 0.0, MAX_AGE_DAYS,
     "Time from the baseline_file's record to this run's start: the offsets' prior std grows by the machine "
     "file's [probes] offset_drift_um_per_day per day (in quadrature); 0: just commissioned"),
    ("q_std_velocity_um_s", -1.0, "um/s", -1.0, MAX_PROBE_UM * 1000.0,
     f"Process-noise std per step of every velocity state; -1: the recommended "
     f"{RECOMMENDED_DISPLACEMENT_PROCESS_STD_M * 1e6:g} um x 2 pi speed_hz; the paper's 10 um/s makes the "
     "filter inconsistent (NIS/m 0.14)"),
)  # fmt: skip
"""Real parameters of this FMU that are not in the estimator's configuration table: name, start, unit, min,
max, description. The others (:data:`oilwatch.estimator.boundary_parameters.ESTIMATOR_PARAMETERS`: noise,
process noise, gate, alarm) are generated from the configuration classes."""


PRESET_TABLE = -1
"""``bearing_table`` start value of the estimator: the preset's (``Preset.follow_operating_point``)."""


def declare_parameters(slave) -> None:
    tables = "; ".join(f"{p.name}: {int(p.follow_operating_point)}" for p in PRESETS)
    declare_machine_parameters(slave, PRESET_TABLE, f"; -1: the preset's ({tables})")
    slave.declare_string(
        "preset",
        "parameter",
        start=DEFAULT_PRESET,
        description="The configuration the parameters at -1 take their values from: "
        + "; ".join(f"{p.name}: {p.description}" for p in PRESETS),
    )
    for name, start, unit, low, high, text in OWN_REALS:
        slave.declare_real(
            name, "parameter", start=start, unit=unit, minimum=low, maximum=high, description=text
        )
    for p in ESTIMATOR_PARAMETERS:
        slave.declare_real(
            p.name,
            "parameter",
            start=p.default,
            unit=p.unit,
            minimum=p.low,
            maximum=p.high,
            description=p.description,
        )
    slave.declare_string(
        "baseline_file",
        "parameter",
        start="",
        description="Commissioning baseline (JSON written by 'oilwatch baseline'): the probe offsets' "
        "prior and, when it has them, the runout vectors (they replace the machine file's [probes] "
        "runout_* keys) and the bearings' clearances a coast-down measured (the model takes them; they "
        "need bearing_table = 1); an absolute path or one relative to this FMU's resources folder; "
        "empty: none",
    )
    slave.declare_integer(
        "velocity_channels",
        "parameter",
        start=0,
        minimum=0,
        maximum=1,
        description="0: the four displacements only (default); 1: plus differentiated velocities "
        "with R = noise^2 I (the paper)",
    )


def declare_inputs_outputs(slave) -> None:
    real = slave.declare_real
    for name in POSITIONS:
        real(
            f"{name}_um",
            "input",
            start=0.0,
            unit="um",
            description=f"Measured signal of probe {name}: the shaft's displacement in bearing {name[1]} "
            f"from the bearing centre along the probe's axis ({name[0]} turned by probe_angle_deg), plus "
            "the probe's zero offset; NaN or infinite: no measurement this step",
        )
    real(
        "t_sample_s",
        "input",
        start=-1.0,
        unit="s",
        description="Time the positions refer to (connect to the plant's t_sample_s); -1 (not "
        "connected): the end of the communication step",
    )
    real(
        "rotor_angle_deg",
        "input",
        start=KEYPHASOR_UNCONNECTED,
        unit="deg",
        description="Rotor angle at the sample from the keyphasor's once-per-revolution mark, 0-360 "
        "(connect to the plant's rotor_angle_deg, or a keyphasor-derived angle); with bearing_table = 1 "
        "the unbalance phase then follows it instead of the integral of speed_hz; -1 (not connected) "
        "or non-finite: the integral of speed_hz",
    )
    for b in (1, 2):
        real(
            f"q{b}_est_ml_min",
            "output",
            start=0.0,
            unit="ml/min",
            minimum=0.0,
            description=f"Estimated supply flowrate of bearing {b} (the filter's, or during a model_mismatch "
            "of 1 the one read from the static change relative to the baseline)",
        )
    for b in (1, 2):
        real(
            f"q{b}_std_ml_min",
            "output",
            start=0.0,
            unit="ml/min",
            minimum=0.0,
            description=f"Standard deviation of the bearing-{b} estimate: from the covariance P while the "
            "model is consistent, else as model_mismatch says (the static change's, or, held, the estimate's "
            "RMS error under the flowrates' prior)",
        )
    real(
        "nis",
        "output",
        start=0.0,
        unit="1",
        minimum=0.0,
        description="Normalized innovation squared of the last sample; averages n_channels when the "
        "filter is consistent (0 when no update)",
    )
    slave.declare_integer(
        "n_channels",
        "output",
        start=0,
        minimum=0,
        maximum=8,
        description="Measurement channels used by the last update (4 or 8; 0: none)",
    )
    real(
        "t_estimate_s",
        "output",
        start=-1.0,
        unit="s",
        description="Time the estimate refers to (the last sample processed); -1 before the first",
    )
    slave.declare_boolean(
        "converged",
        "output",
        start=False,
        description="Both flowrate stds below 3 % of nominal and drift below 1 % over 1 s",
    )
    for b in (1, 2):
        slave.declare_boolean(
            f"starved{b}",
            "output",
            start=False,
            description=f"Starvation alarm of bearing {b} (hold times and hysteresis)",
        )
    slave.declare_boolean(
        "measurement_ok",
        "output",
        start=False,
        description="The last sample updated the filter (at least one probe channel was used)",
    )
    slave.declare_boolean(
        "model_consistent",
        "output",
        start=True,
        description="The windowed NIS test passes: the machine still matches the estimator's model",
    )
    codes = ", ".join(f"{code} {name}" for code, name in enumerate(STATUS_NAMES))
    for name in POSITIONS:
        slave.declare_integer(
            f"probe_status_{name}",
            "output",
            start=0,
            minimum=0,
            maximum=len(STATUS_NAMES) - 1,
            description=f"Health of probe {name}: {codes} (a faulty probe is excluded until it recovers)",
        )
    for name, unit, text, start in nuisance_names():
        real(name, "output", start=start, unit=unit, description=text)
    declare_start_outputs(slave)  # the value references of the outputs before them stay as they were
    codes = ", ".join(f"{code} {name}" for code, name in enumerate(MISMATCH_NAMES))
    slave.declare_integer(
        "model_mismatch",
        "output",
        start=0,
        minimum=0,
        maximum=len(MISMATCH_NAMES) - 1,
        description=f"Model-mismatch status: {codes}. 1: model_consistent has failed and q*_est, q*_std and "
        "the alarms come from the static change relative to the baseline_file's record; 2: no such reference "
        "applies, the alarms are held (neither set nor cleared) and q*_std is the estimate's RMS error under "
        "the flowrates' prior (nominal, a quarter of it)",
    )
