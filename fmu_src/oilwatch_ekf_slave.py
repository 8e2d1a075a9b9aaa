"""OilFlowEKF: the oil-flow Extended Kalman Filter (paper section 2.4, Eqs. 17-24) as an FMU.

A thin FMI 2.0 co-simulation shell (pythonfmu) around ``estimator.OilFlowEKF`` running on
``models.system.augmented.GridAugmentedModel``, the fast (q1, q2)-grid map of the Craig-Bampton reduced
rotor-bearing system built from the machine file at the start speed with the plant's unbalance
(``bearing_table = 0``), or, with ``bearing_table = 1``, on
``models.system.operating_model.OperatingAugmentedModel``, which follows the measured inputs ``speed_hz`` and
``oil_temperature_c`` (the same inputs as the plant's, held over each step) and can estimate a viscosity
factor per bearing (``viscosity_factor_prior_std > 0``). It takes the four
measured bearing positions (named as the RotorBearingPlant's outputs, so a master connects them by name) and
outputs both supply-flowrate estimates with their standard deviations from P, the normalized innovation
squared, a convergence flag, one starvation alarm per bearing and whether the sample was used.

Default tuning (deliberately not the paper's): the process-noise stds default to the estimator's recommended
values (``EKFConfig.recommended``): 0.1 um and 0.1 um x Omega (47.1 um/s for the bundled turbine) per step on
the dynamic states and 0.1 ml/min on the flowrates. The paper's 10 um and 10 um/s made the filter inconsistent
on the plant (NIS/m 0.14 instead of 1, so its stds are not to be trusted), more biased (mean constant-flow
bias 0.59 % against 0.09 % over 5 cases x 2 seeds) and slower to alarm (1.2-1.5 s after a sudden drop against
0.45-0.6 s). To run the paper's filter, set ``q_std_displacement_um = 10``, ``q_std_velocity_um_s = 10``,
``q_std_flow_ml_min = 0.1`` and ``velocity_channels = 1``.

Time alignment. The filter's discrete model is exact for samples on the grid ``t_k = k sample_period_s`` (the
unbalance phase counts from t = 0), and a 1 ms misalignment at the turbine's speed is a 27 deg phase error
that ruins the estimate. Each ``doStep(t, h)`` therefore takes the time its sample refers to from the input
``t_sample_s`` (connect it to the plant's output of the same name) or, while it stays at its start value -1
(not connected, e.g. a real plant), uses ``t + h`` (Gauss-Seidel order: the plant stepped first). A sample
whose time has not advanced (a repeated sample) is not used twice; a gap of several periods is predicted
through without updates; a sample off the grid is skipped (logged once). With a Jacobi master (libcosim) the
plant's outputs arrive one step late but with their own time stamp, so the filter stays aligned and its
estimate (time stamp ``t_estimate_s``) lags one step. A NaN or infinite position drops that probe's channel
from the update (the others are used); a NaN or infinite ``t_sample_s`` is a skipped sample (predicted
through), never an error.

Outputs and the fast path. The per-step inputs (positions, ``t_sample_s``, ``rotor_angle_deg``, ``speed_hz``,
``oil_temperature_c``) and the outputs published with every step (:data:`STEP_OUTPUTS`) live in the base
class's arrays, which oilwatch's FMI 2.0 loader serves in C (:mod:`fmu_src.slave_base`: the fast path). Each
step writes its report into the output array with one numpy division (:data:`REPORT_COLUMNS`); the nuisance
estimates cost a covariance read and are published only when a host reads one of them (after the filter
stepped). With ``bearing_table`` 0 the loader runs the plain sample (the next one on the grid, the
operating point unchanged) in one compiled C function without the GIL (:mod:`fmu_src.ekf_plain_step`, the
same arithmetic); every other sample goes through :meth:`OilFlowEKF.step` here.

The estimator's numba kernels compile on first use in a process (5-10 s); ``setup`` warms them up during
initialization and logs the time, so that no ``doStep`` pays for it.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
from pythonfmu import DefaultExperiment
from pythonfmu.enums import Fmi2Causality

from estimator.baseline import load_baseline, load_runout
from estimator.channels import STATUS_NAMES
from estimator.config import (
    ESTIMATOR_PARAMETERS,
    INITIAL_FLOWRATE_STD_FRACTION,
    ML_MIN,
    OFFSET_PRIOR_FROM_MACHINE,
    RECOMMENDED_DISPLACEMENT_PROCESS_STD_M,
    EKFConfig,
    config_from_parameters,
    nuisance_names,
    nuisance_values,
)
from estimator.factory import make_estimator
from estimator.reports import ReportView
from estimator.runout import runout_of_probes
from estimator.step_kernel import (
    REPORT_CONSISTENT,
    REPORT_CONVERGED,
    REPORT_FLOWRATE,
    REPORT_NIS,
    REPORT_OK,
    REPORT_ROWS,
    REPORT_STARVED,
    REPORT_STATUS,
    REPORT_STD,
)
from fmu_src.blas_threads import limit_blas_threads
from fmu_src.loader_link import bind_plain_step
from fmu_src.machine_parameters import (
    declare_machine_parameters,
    held_operating_point,
    machine_of,
    operating_conditions,
    probe_angle_deg,
    require_oil,
    rotor_bearing_system,
)
from fmu_src.slave_base import OilwatchSlave
from models.probes import read_probes
from models.system.augmented import GridAugmentedModel
from models.system.operating_model import build_operating_model
from models.validation import InputError

SAMPLING_PERIOD_S = 1e-3
SECONDS_PER_DAY = 86400.0
POSITIONS = ("x1", "y1", "x2", "y2")
VELOCITY_MODES = ("displacement-only", "paper", "correlated")
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
)
"""The outputs taken from the step report: name, report column (``estimator.step_kernel`` REPORT_* layout),
divisor (SI -> field units; flags and counts as 0/1 and whole numbers)."""
STEP_OUTPUTS = (*(name for name, _, _ in REPORT_OUTPUTS), "t_estimate_s")
"""The outputs published with every step (the fast path's output array, in this order)."""
T_ESTIMATE_INDEX = STEP_OUTPUTS.index("t_estimate_s")
REPORT_COLUMNS = np.array([column for _, column, _ in REPORT_OUTPUTS])
REPORT_DIVISORS = np.array([divisor for _, _, divisor in REPORT_OUTPUTS])
OWN_REALS = (
    ("sample_period_s", SAMPLING_PERIOD_S, "s", 1e-5, 0.01,
     "Sampling period of the filter's discrete model; its samples lie on t = k period"),
    ("q_initial_ml_min", 0.0, "ml/min", 0.0, None,
     "Initial flowrate estimate of both bearings (within the coefficient table's range); 0: the nominal"),
    ("q_nominal_ml_min", 0.0, "ml/min", 0.0, None,
     "Nominal flowrate, the alarm thresholds' reference; 0: the machine file's nominal flowrate"),
    ("baseline_age_days", 0.0, "d", 0.0, None,
     "Time from the baseline_file's record to this run's start: the offsets' prior std grows by the machine "
     "file's [probes] offset_drift_um_per_day per day (in quadrature); 0: just commissioned"),
    ("q_std_velocity_um_s", -1.0, "um/s", -1.0, None,
     f"Process-noise std per step of every velocity state; -1: the recommended "
     f"{RECOMMENDED_DISPLACEMENT_PROCESS_STD_M * 1e6:g} um x 2 pi speed_hz; the paper's 10 um/s makes the "
     "filter inconsistent (NIS/m 0.14)"),
)  # fmt: skip
"""Real parameters of this FMU that are not in the estimator's configuration table: name, start, unit, min,
max, description. The others (:data:`estimator.config.ESTIMATOR_PARAMETERS`: noise, process noise, gate,
alarm) are generated from the configuration classes."""


class OilFlowEKF(OilwatchSlave):
    """FMI slave of the oil-flow estimator (see the module docstring)."""

    author = "oilwatch"
    description = (
        "Augmented-state EKF estimating both bearings' oil supply flowrates from the four measured shaft "
        "positions, with per-bearing starvation alarms (default Q: the recommended 0.1 um / 0.1 um x Omega "
        "per step, not the paper's 10 um / 10 um/s)"
    )
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=20.0, step_size=SAMPLING_PERIOD_S)
    state_attributes = ("filter_state", "keyphasor_state")
    buffered_inputs = STEP_INPUTS
    buffered_outputs = STEP_OUTPUTS

    def __init__(self, **kwargs):
        limit_blas_threads()
        super().__init__(**kwargs)
        self.filter = None  # estimator.factory.make_estimator's: a filter, or the start bank
        self._measurement = np.zeros(4)
        self._measurement_row = self._measurement.reshape(1, 4)  # the compiled plain step's view
        self._missing = np.full(4, np.nan)
        self._warned_off_grid = False
        self._nuisance_names = [row[0] for row in nuisance_names()]
        self._nuisances_published = 0  # the filter's step count when the nuisances were last published
        self._keyphasor_cell = np.full(1, np.nan)  # keyphasor_state's storage (the compiled step writes it)
        self._plain_step = None  # the bound compiled step's table, kept alive: the loader points into it
        self._declare_parameters()
        self._declare_inputs_outputs()
        self._nuisance_outputs = self._nuisance_references()
        self._report_outputs = self._outputs[: len(REPORT_OUTPUTS)]  # a view the step writes into

    def _declare_parameters(self) -> None:
        declare_machine_parameters(self)
        for name, start, unit, low, high, text in OWN_REALS:
            self.declare_real(
                name, "parameter", start=start, unit=unit, minimum=low, maximum=high, description=text
            )
        for p in ESTIMATOR_PARAMETERS:
            self.declare_real(
                p.name,
                "parameter",
                start=p.default,
                unit=p.unit,
                minimum=p.low,
                maximum=p.high,
                description=p.description,
            )
        self.declare_string(
            "baseline_file",
            "parameter",
            start="",
            description="Commissioning baseline (JSON written by 'oilwatch baseline'): the probe offsets' "
            "prior and, when it has them, the runout vectors (they replace the machine file's [probes] "
            "runout_* keys); an absolute path or one relative to this FMU's resources folder; empty: none",
        )
        self.declare_integer(
            "velocity_channels",
            "parameter",
            start=0,
            minimum=0,
            maximum=2,
            description="0: the four displacements only (default); 1: plus differentiated velocities "
            "with R = noise^2 I (the paper); 2: plus velocities with their exact correlated noise",
        )

    def _declare_inputs_outputs(self) -> None:
        real = self.declare_real
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
                description=f"Estimated supply flowrate of bearing {b}",
            )
        for b in (1, 2):
            real(
                f"q{b}_std_ml_min",
                "output",
                start=0.0,
                unit="ml/min",
                minimum=0.0,
                description=f"Standard deviation of the bearing-{b} estimate (from the covariance P)",
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
        self.declare_integer(
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
        self.declare_boolean(
            "converged",
            "output",
            start=False,
            description="Both flowrate stds below 3 % of nominal and drift below 1 % over 1 s",
        )
        for b in (1, 2):
            self.declare_boolean(
                f"starved{b}",
                "output",
                start=False,
                description=f"Starvation alarm of bearing {b} (hold times and hysteresis)",
            )
        self.declare_boolean(
            "measurement_ok",
            "output",
            start=False,
            description="The last sample updated the filter (at least one probe channel was used)",
        )
        self.declare_boolean(
            "model_consistent",
            "output",
            start=True,
            description="The windowed NIS test passes: the machine still matches the estimator's model",
        )
        codes = ", ".join(f"{code} {name}" for code, name in enumerate(STATUS_NAMES))
        for name in POSITIONS:
            self.declare_integer(
                f"probe_status_{name}",
                "output",
                start=0,
                minimum=0,
                maximum=len(STATUS_NAMES) - 1,
                description=f"Health of probe {name}: {codes} (a faulty probe is excluded until it recovers)",
            )
        for name, unit, text, start in nuisance_names():
            real(name, "output", start=start, unit=unit, description=text)

    # --------------------------------------------------------------------- initialization
    @property
    def filter_state(self):
        """The estimator's complete state (for fmi2GetFMUstate / fmi2SetFMUstate)."""
        return None if self.filter is None else self.filter.get_state()

    @filter_state.setter
    def filter_state(self, state) -> None:
        if state is not None:
            self.filter.set_state(state)
            self._nuisances_published = self.filter.step_count  # the outputs were restored with the state

    @property
    def keyphasor_state(self) -> float | None:
        """The keyphasor angle of the last sample [rad] (None: none): where the next prediction starts."""
        angle = self._keyphasor_cell.item(0)
        return None if math.isnan(angle) else angle

    @keyphasor_state.setter
    def keyphasor_state(self, angle: float | None) -> None:
        self._keyphasor_cell[0] = math.nan if angle is None else angle

    def _nuisance_references(self) -> frozenset[int]:
        """Value references of the nuisance estimates, published together when the host reads one of them
        (module docstring)."""
        nuisances = set(self._nuisance_names)
        return frozenset(
            v.value_reference
            for v in self.vars.values()
            if v.causality == Fmi2Causality.output and v.local_name in nuisances
        )

    def refresh_outputs(self, vrs) -> None:
        """Publish the nuisance estimates if they are stale (the filter stepped since) and among ``vrs``."""
        if self.filter is None or self.filter.step_count == self._nuisances_published:
            return
        if not self._nuisance_outputs.isdisjoint(vrs):
            self._publish_nuisances()

    def validate_parameters(self) -> None:
        if self.q_std_velocity_um_s < 0.0 and self.q_std_velocity_um_s != -1.0:
            raise InputError(
                f"q_std_velocity_um_s must be >= 0 um/s or -1 (recommended), got {self.q_std_velocity_um_s:g}"
            )
        if self.alarm_off_fraction < self.alarm_on_fraction:
            raise InputError(
                f"alarm_off_fraction must be >= alarm_on_fraction ({self.alarm_on_fraction:g}) for "
                f"hysteresis, got {self.alarm_off_fraction:g}"
            )
        period = self.sample_period_s
        if self.start_time < 0.0 or abs(self.start_time / period - round(self.start_time / period)) > (
            GRID_TOLERANCE
        ):
            raise InputError(
                f"the start time must be >= 0 and a multiple of sample_period_s = {period:g} s (the "
                f"unbalance phase counts from t = 0), got {self.start_time:g} s"
            )

    def setup(self) -> None:
        started = time.perf_counter()
        system = rotor_bearing_system(
            self.machine_file,
            self.resources,
            self.speed_hz if self.bearing_table == 0 else 0.0,  # 1: the reference grid at the nominal speed
            self.unbalance_g_mm,
            self.unbalance_phase_deg,
            reduced=True,
        )
        nominal = (
            self.q_nominal_ml_min if self.q_nominal_ml_min > 0.0 else system.nominal_flowrate_m3_s / ML_MIN
        )
        initial = self.q_initial_ml_min if self.q_initial_ml_min > 0.0 else nominal
        low, high = (bound / ML_MIN for bound in system.flowrate_bounds_m3_s)
        if not low <= initial <= high:
            name = (
                "q_initial_ml_min"
                if self.q_initial_ml_min > 0.0
                else "the nominal flowrate (q_initial_ml_min 0)"
            )
            raise InputError(
                f"{name} must lie in the coefficient table's range [{low:.1f}, {high:.1f}] ml/min, "
                f"got {initial:g} ml/min"
            )
        machine = machine_of(self.machine_file, self.resources)
        self._machine = machine
        self._start_conditions = operating_conditions(self, machine)
        self._start_inputs = (self.speed_hz, self.oil_temperature_c)
        require_oil(self, machine)
        if self.bearing_table == 1:
            model = build_operating_model(system, machine, self.sample_period_s)
        elif self.viscosity_factor_prior_std > 0.0:
            raise InputError("viscosity_factor_prior_std > 0 needs bearing_table = 1")
        else:
            model = GridAugmentedModel(system, self.sample_period_s)
        self.filter = make_estimator(
            model, self._config(machine, nominal, initial, system.speed_hz, *self._baseline(machine))
        )
        self._first_sample_time_s = self.filter.config.first_sample_time_s
        built = time.perf_counter()
        self._warm_up()
        self.log(
            f"{self.instance_name}: reduced model ({model.n_states} states) built in "
            f"{built - started:.1f} s; "
            f"numba kernels compiled or loaded in {time.perf_counter() - built:.1f} s (once per process, "
            "during initialization, not in doStep)"
        )
        self._publish()

    def _baseline(self, machine):
        """(offsets prior, runout vectors) of the ``baseline_file`` parameter ((None, None) when empty; a
        relative path is relative to the resources): the prior ``baseline_age_days`` after its record with
        ``machine``'s offset drift bound, the runout None when the baseline has none."""
        if not self.baseline_file:
            return None, None
        path = Path(self.baseline_file)
        if not path.is_absolute() and self.resources:
            path = Path(self.resources) / path
        try:
            drift = read_probes(machine).offset_drift_m_per_day
            prior = load_baseline(path, SECONDS_PER_DAY * self.baseline_age_days, drift)
            return prior, load_runout(path)
        except (InputError, OSError, UnicodeDecodeError) as error:
            reason = error if isinstance(error, InputError) else f"cannot read {path}: {error}"
            raise InputError(f"baseline_file {self.baseline_file!r}: {reason}") from None

    def _config(
        self,
        machine,
        nominal_ml_min: float,
        initial_ml_min: float,
        speed_hz: float,
        baseline,
        baseline_runout,
    ) -> EKFConfig:
        """The estimator's configuration from the parameters (field units -> SI) and the machine file's
        ``[probes]`` (mounting angle and offset prior for the sentinels; the offsets' drift, always). The
        runout vectors the filter subtracts at the model's rotor angle are the baseline's when it has them,
        else those of the ``[probes]`` ``runout_*`` keys (as ``oilwatch estimate`` chooses)."""
        omega = 2.0 * math.pi * speed_hz
        velocity_std = (
            RECOMMENDED_DISPLACEMENT_PROCESS_STD_M * omega
            if self.q_std_velocity_um_s < 0.0
            else self.q_std_velocity_um_s * 1e-6
        )
        probes = read_probes(machine)
        values = {p.name: getattr(self, p.name) for p in ESTIMATOR_PARAMETERS}
        if values["offset_prior_std_um"] == OFFSET_PRIOR_FROM_MACHINE:
            values["offset_prior_std_um"] = probes.offset_prior_std_m * 1e6
        return config_from_parameters(
            values,
            probe_angle_deg=probe_angle_deg(self, machine),
            offset_random_walk_m_sqrt_s=probes.offset_random_walk_m_sqrt_s,
            velocity_noise=VELOCITY_MODES[self.velocity_channels],
            velocity_process_std_m_s=velocity_std,
            q_initial_m3_s=initial_ml_min * ML_MIN,
            q_nominal_m3_s=nominal_ml_min * ML_MIN,
            first_sample_time_s=round(self.start_time / self.sample_period_s) * self.sample_period_s,
            initial_flowrate_std_m3_s=INITIAL_FLOWRATE_STD_FRACTION * nominal_ml_min * ML_MIN,
            offset_baseline=baseline,
            runout=runout_of_probes(probes) if baseline_runout is None else baseline_runout,
        )

    def _warm_up(self) -> None:
        """Run the compiled paths (predict, update, skipped sample) once, then return to the initial state;
        compile (or load) the compiled plain step when this configuration has one."""
        for sample in (self._measurement, self._measurement, self._missing):
            self.filter.step(sample, *self._operating_point(self.speed_hz, self.oil_temperature_c))
        self.filter.reset()
        if self._has_plain_step():
            from fmu_src import ekf_plain_step  # noqa: F401 - compiles its C entry on import

    def _operating_point(self, speed: float, temperature: float) -> tuple[float | None, float | None]:
        """(speed [Hz], oil temperature [degC]) for the filter from the inputs ``speed`` and ``temperature``
        (bearing_table = 0: None, and InputError when they left their start values)."""
        if self.bearing_table == 1:
            return operating_conditions(self, self._machine)
        if (speed, temperature) != self._start_inputs:  # the check costs only then
            held_operating_point(self, self._machine, self._start_conditions)
        return None, None

    def _bind_fast_path(self) -> None:
        """The base class's binding, then, on the grid model at one speed, the compiled plain step: the
        loader's doStep runs the plain sample without entering Python."""
        super()._bind_fast_path()
        table = self.plain_step_table() if self.fast_path_bound else None
        if table is not None and bind_plain_step(self, table):
            self._plain_step = table

    def _has_plain_step(self) -> bool:
        if self.filter is None or self.bearing_table != 0:
            return False
        return self.filter.grid_batch_arguments() is not None

    def plain_step_table(self):
        """The compiled plain step on this slave's arrays (:class:`fmu_src.ekf_plain_step.PlainStepTable`),
        None unless its library step is one compiled call (``bearing_table`` 0, no nuisance in the
        transition)."""
        if not self._has_plain_step():
            return None
        from fmu_src.ekf_plain_step import PlainStepTable  # compiled in _warm_up, for this configuration only

        constants = (self._first_sample_time_s, self.sample_period_s, *self._start_inputs, GRID_TOLERANCE)
        return PlainStepTable(
            self.filter.grid_batch_arguments(),
            (self._inputs, self._outputs, self._measurement_row, self._keyphasor_cell),
            constants,
            REPORT_COLUMNS,
            REPORT_DIVISORS,
            len(STEP_INPUTS),
            T_ESTIMATE_INDEX,
        )

    # ------------------------------------------------------------------------------- step
    def step(self, current_time: float, step_size: float) -> bool:
        end = current_time + step_size
        # the inputs' array (STEP_INPUTS order) read once: the step's Python is the FMU's per-step cost
        x1, y1, x2, y2, stamp, keyphasor, speed, temperature, _, _ = self._inputs.tolist()
        bad_stamp = not math.isfinite(stamp)  # NaN or inf: a skipped sample, predicted through
        sample_time = end if (bad_stamp or stamp < 0.0) else stamp
        period = self.sample_period_s
        if sample_time > end + GRID_TOLERANCE * period:
            raise InputError(
                f"t_sample_s = {sample_time:.9g} s lies after the end of the communication step "
                f"({end:.9g} s): connect it to the plant's t_sample_s"
            )
        position = (sample_time - self._first_sample_time_s) / period
        index = round(position)
        if abs(position - index) > GRID_TOLERANCE:
            if not self._warned_off_grid:
                self._warned_off_grid = True
                self.log(
                    f"{self.instance_name}: sample at t = {sample_time:.9g} s is off the filter's grid "
                    f"(k x {period:g} s) and is skipped; align the communication step with sample_period_s"
                )
            return True
        if index < self.filter.step_count:
            return True  # a repeated sample: already used
        operating = self._operating_point(speed, temperature)
        while self.filter.step_count < index:
            self.filter.step(self._missing, *operating)  # a gap: predict through it
            self.keyphasor_state = None
        measurement = self._measurement
        if bad_stamp:
            measurement[:] = np.nan
        else:
            measurement[0] = x1 * 1e-6
            measurement[1] = y1 * 1e-6
            measurement[2] = x2 * 1e-6
            measurement[3] = y2 * 1e-6
        angle = self.keyphasor_state if self.bearing_table == 1 else None
        self._publish_core(self.filter.step(measurement, *operating, angle))
        connected = math.isfinite(keyphasor) and keyphasor >= 0.0 and not bad_stamp
        self.keyphasor_state = math.radians(keyphasor) if connected else None
        return True

    def _publish(self, report: ReportView | None = None) -> None:
        """Copy a step report (default: the last one, rebuilt from the state) to all outputs now."""
        self._publish_core(report if report is not None else self.filter.current_report())
        self._publish_nuisances()

    def _publish_nuisances(self) -> None:
        self._nuisances_published = self.filter.step_count
        for name, value in zip(self._nuisance_names, nuisance_values(self.filter), strict=True):
            setattr(self, name, value)

    def _publish_core(self, report: ReportView) -> None:
        """Write a step report into the output array (:data:`STEP_OUTPUTS`): one division of its columns."""
        np.divide(report.values[REPORT_COLUMNS], REPORT_DIVISORS, out=self._report_outputs)
        steps = report.step + 1
        self._outputs[T_ESTIMATE_INDEX] = (
            -1.0 if steps == 0 else self._first_sample_time_s + (steps - 1) * self.sample_period_s
        )
