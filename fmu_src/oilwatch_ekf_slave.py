"""OilFlowEKF: the oil-flow Extended Kalman Filter (paper section 2.4, Eqs. 17-24) as an FMU.

A thin FMI 2.0 co-simulation shell (pythonfmu) around ``estimator.OilFlowEKF`` running on
``oilwatch.models.system.augmented.GridAugmentedModel``, the fast (q1, q2)-grid map of the Craig-Bampton
reduced rotor-bearing system built from the machine file at the start speed with the plant's unbalance
(``bearing_table = 0``), or, with ``bearing_table = 1``, on
``oilwatch.models.system.operating_model.OperatingAugmentedModel``, which follows the measured inputs
``speed_hz`` and ``oil_temperature_c`` (the same inputs as the plant's, held over each step) and can estimate
a viscosity factor per bearing (``viscosity_factor_prior_std > 0``). It takes the four
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

Outputs and the fast path. The per-step inputs (positions, ``t_sample_s``, ``rotor_angle_deg``,
``speed_hz``, ``oil_temperature_c``) and the outputs published with every step
(:data:`oilwatch.fmu_src.ekf_variables.STEP_OUTPUTS`) live in the base class's arrays, which oilwatch's FMI
2.0 loader serves in C (:mod:`oilwatch.fmu_src.slave_base`: the fast path). Each step writes its report into
the output array with one numpy division (:data:`oilwatch.fmu_src.ekf_variables.REPORT_COLUMNS`); the nuisance
estimates cost a covariance read and are published only when a host reads one of them (after the filter
stepped). With ``bearing_table`` 0 the loader runs the plain sample (the next one on the grid, the operating
point unchanged) in one compiled C function without the GIL (:mod:`oilwatch.fmu_src.ekf_plain_step`, the
same arithmetic); every other sample goes through :meth:`OilFlowEKF.step` here.

Where the rest lives: the variables (names, units, descriptions, the order of the fast path's arrays) in
:mod:`oilwatch.fmu_src.ekf_variables`; the parameters' checks, the model and the estimator's configuration in
:mod:`oilwatch.fmu_src.ekf_configuration`; the compiled plain step in :mod:`oilwatch.fmu_src.ekf_plain_step`.

The estimator's numba kernels compile on first use in a process (5-10 s); ``setup`` warms them up during
initialization and logs the time, so that no ``doStep`` pays for it. Initialization also takes the start
time's sample as a skipped one (:meth:`OilFlowEKF._take_start_sample`), which the first doStep would
otherwise predict through before the host's first sample, one period later, and runs the slave's step on a
host's first samples and undoes them (:meth:`OilFlowEKF._warm_step`), so that the first doStep runs
specialised Python.
"""

from __future__ import annotations

import copy
import math
import time

import numpy as np
from pythonfmu import DefaultExperiment
from pythonfmu.enums import Fmi2Causality

from oilwatch.estimator.factory import make_estimator
from oilwatch.estimator.nuisance_outputs import nuisance_names, nuisance_values
from oilwatch.estimator.reports import ReportView
from oilwatch.fmu_src.blas_threads import limit_blas_threads
from oilwatch.fmu_src.ekf_configuration import (
    baseline_prior,
    check_parameters,
    estimator_config,
    estimator_model,
    flowrates_ml_min,
)
from oilwatch.fmu_src.ekf_start_outputs import start_values
from oilwatch.fmu_src.ekf_variables import (
    GRID_TOLERANCE,
    REPORT_COLUMNS,
    REPORT_DIVISORS,
    REPORT_OUTPUTS,
    SAMPLING_PERIOD_S,
    SETTLED_INDEX,
    START_CHOOSING_INDEX,
    START_SETTLING_INDEX,
    START_SLICE,
    STEP_INPUTS,
    STEP_OUTPUTS,
    T_ESTIMATE_INDEX,
    declare_inputs_outputs,
    declare_parameters,
)
from oilwatch.fmu_src.loader_link import bind_plain_step
from oilwatch.fmu_src.machine_parameters import (
    held_operating_point,
    machine_of,
    operating_conditions,
    require_oil,
    rotor_bearing_system,
)
from oilwatch.fmu_src.slave_base import OilwatchSlave
from oilwatch.models.validation import InputError

WARM_UP_STEPS = 8
"""Samples :meth:`OilFlowEKF._warm_step` takes and undoes at the end of initialization: the calls after which
CPython (3.11) specialises a function's bytecode."""
STAMP_INPUT = STEP_INPUTS.index("t_sample_s")


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
        self.filter = None  # oilwatch.estimator.factory.make_estimator's: a filter, or the start bank
        self._measurement = np.zeros(4)
        self._measurement_row = self._measurement.reshape(1, 4)  # the compiled plain step's view
        self._missing = np.full(4, np.nan)
        self._warned_off_grid = False
        self._nuisance_names = [row[0] for row in nuisance_names()]
        self._nuisances_published = 0  # the filter's step count when the nuisances were last published
        self._keyphasor_cell = np.full(1, np.nan)  # keyphasor_state's storage (the compiled step writes it)
        self._plain_step = None  # the bound compiled step's table, kept alive: the loader points into it
        self._start_sample_taken = None  # (filter state before it, operating point): _take_start_sample
        declare_parameters(self)
        declare_inputs_outputs(self)
        self._nuisance_outputs = self._nuisance_references()
        self._report_outputs = self._outputs[: len(REPORT_OUTPUTS)]  # a view the step writes into

    # --------------------------------------------------------------------- initialization
    @property
    def filter_state(self):
        """The estimator's complete state (for fmi2GetFMUstate / fmi2SetFMUstate): the state before a start
        sample taken ahead (:meth:`_take_start_sample`), so that a host sees none."""
        taken = self._pending_start_sample()
        if taken is not None:
            return taken[0]
        return None if self.filter is None else self.filter.get_state()

    @filter_state.setter
    def filter_state(self, state) -> None:
        self._start_sample_taken = None
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
        check_parameters(self)

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
        nominal, initial = flowrates_ml_min(self, system)
        machine = machine_of(self.machine_file, self.resources)
        self._machine = machine
        self._start_conditions = operating_conditions(self, machine)
        self._start_inputs = (self.speed_hz, self.oil_temperature_c)
        require_oil(self, machine)
        model = estimator_model(self, system, machine)
        config = estimator_config(
            self, machine, nominal, initial, system.speed_hz, *baseline_prior(self, machine)
        )
        self.filter = make_estimator(model, config)
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

    def _warm_up(self) -> None:
        """Run the compiled paths (skipped sample, predict, update) once, then return to the initial state;
        compile (or load) the compiled plain step when this configuration has one. The first sample is a
        skipped one, as the start time's is when the host's first input is the plant's sample after one
        step: the first prediction then starts where the first doStep's does (its model's re-centring is
        kept, see ``operating_model.CENTRES_KEPT``)."""
        for sample in (self._missing, self._measurement, self._missing):
            self.filter.step(sample, *self._operating_point(self.speed_hz, self.oil_temperature_c))
        self.filter.reset()
        if self._has_plain_step():
            from oilwatch.fmu_src import ekf_plain_step  # noqa: F401 - compiles its C entry on import

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
        self._take_start_sample()
        if table is not None and bind_plain_step(self, table):
            self._plain_step = table
            self._warm_plain_step(table)
        else:
            self._warm_step()

    def _take_start_sample(self) -> None:
        """Take the start time's sample as a skipped one now, keeping the state before it. A host's first
        input is usually the plant's sample one period after the start, so the first doStep would predict
        through the start time's sample first: two samples' work (five filters' each in a start bank).
        :meth:`step` keeps it when the first sample comes later at the same operating point, else returns
        to the state before it; the compiled plain step keeps it by taking a later sample, which only it
        takes at the start's operating point (:meth:`_pending_start_sample`)."""
        if self.filter.step_count != 0:
            return
        operating = self._operating_point(self.speed_hz, self.oil_temperature_c)
        before = self.filter.get_state()
        self.filter.step(self._missing, *operating)
        self._start_sample_taken = (before, operating)

    def _warm_step(self) -> None:
        """Take :data:`WARM_UP_STEPS` samples through :meth:`step` as a host's first ones (one period apart
        from the first sample time, the other inputs as initialization left them) and return to the state
        before them, so that the first doStep runs Python the interpreter has already specialised (the
        filter's warm-up in :meth:`setup` calls the step's functions only a few times, the slave's own step
        never). Everything a step changes goes back: the filter's state, the start sample taken ahead, the
        input, output and measurement arrays, the keyphasor and the log; but each operating model keeps the
        correction centre the first sample placed, where the first doStep's transition would place it again.
        A sample's error is left to the first doStep, which reports it."""
        state, taken = self.filter.get_state(), copy.deepcopy(self._start_sample_taken)
        kept = (self._nuisances_published, self._warned_off_grid, len(self.log_queue))
        arrays = [
            (array, array.copy())
            for array in (self._inputs, self._outputs, self._measurement, self._keyphasor_cell)
        ]
        first, period = self._first_sample_time_s, self.sample_period_s
        after_first = None
        try:
            for k in range(WARM_UP_STEPS):
                self._inputs[STAMP_INPUT] = first + (k + 1) * period
                self.step(first + k * period, period)
                if k == 0:
                    after_first = self.filter.get_state()
        except Exception:  # the same sample fails again at the first doStep, which reports it
            pass
        # the first sample's transition placed each model's correction centre at its point: kept placed, so
        # that the first doStep, taking the same point, does not re-centre (undone with the start sample
        # when the first sample comes at another operating point: _settle_start_sample)
        self.filter.set_state(
            state if after_first is None else self.filter.with_model_centre_of(state, after_first)
        )
        self._start_sample_taken = taken
        self._nuisances_published, self._warned_off_grid, logged = kept
        del self.log_queue[logged:]
        for array, values in arrays:
            np.copyto(array, values)

    def _pending_start_sample(self):
        """The start sample taken ahead (:meth:`_take_start_sample`: the state before it, its operating point)
        while no later sample has settled it, else None. The compiled plain step settles it without telling
        the slave: it takes only samples after it at its operating point, which keep it, so a filter past
        its second sample has kept it."""
        if self._start_sample_taken is not None and self.filter.step_count > 1:
            self._start_sample_taken = None
        return self._start_sample_taken

    def _settle_start_sample(self, index: int, operating) -> None:
        """Keep the start sample taken ahead if the first sample is a later one at its operating point, else
        return to the state before it (:meth:`_take_start_sample`)."""
        taken = self._pending_start_sample()
        if taken is None:
            return
        before, taken_at = taken
        self._start_sample_taken = None
        if index < 1 or operating != taken_at:
            self.filter.set_state(before)

    def _warm_plain_step(self, table) -> None:
        """Run the compiled plain step once on the first sample as a host sends it (one period after the
        start, after the start time's sample taken ahead) and undo it, so that the first doStep runs code and
        touches arrays that initialization already ran and touched."""
        from oilwatch.fmu_src.ekf_plain_step import INPUT_STAMP

        inputs = self._inputs
        kept = inputs.copy()
        first, period = self._first_sample_time_s, self.sample_period_s
        inputs[INPUT_STAMP] = first + period
        inputs[-2:] = (first, period)  # the loader's time and step size
        table.step_and_undo()
        inputs[:] = kept

    def _has_plain_step(self) -> bool:
        if self.filter is None or self.bearing_table != 0 or self.filter.settling_steps > 0:
            return False  # a settling start: estimate_settled is not converged's (fmu_src.ekf_start_outputs)
        return self.filter.grid_batch_arguments() is not None

    def plain_step_table(self):
        """The compiled plain step on this slave's arrays
        (:class:`oilwatch.fmu_src.ekf_plain_step.PlainStepTable`), None unless its library step is one
        compiled call (``bearing_table`` 0, no nuisance in the transition)."""
        if not self._has_plain_step():
            return None
        from oilwatch.fmu_src.ekf_plain_step import (
            PlainStepTable,  # compiled in _warm_up, for this configuration only
        )

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
        if self._start_sample_taken is not None:
            self._settle_start_sample(index, self._operating_point(speed, temperature))
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
        outputs = self._outputs
        if outputs.item(START_CHOOSING_INDEX) or outputs.item(START_SETTLING_INDEX):  # a start under way
            self._publish_start()
        connected = math.isfinite(keyphasor) and keyphasor >= 0.0 and not bad_stamp
        self.keyphasor_state = math.radians(keyphasor) if connected else None
        return True

    def _publish(self, report: ReportView | None = None) -> None:
        """Copy a step report (default: the last one, rebuilt from the state) to all outputs now."""
        self._publish_core(report if report is not None else self.filter.current_report())
        self._publish_start()
        self._publish_nuisances()

    def _publish_start(self) -> None:
        """Write the start outputs (:mod:`oilwatch.fmu_src.ekf_start_outputs`) after the report: during a
        start the estimate is not settled, whatever converged says."""
        values = start_values(self.filter, self.sample_period_s)
        self._outputs[START_SLICE] = values
        choosing, _, _, settling_left_s = values
        if choosing or settling_left_s:
            self._outputs[SETTLED_INDEX] = 0.0

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
