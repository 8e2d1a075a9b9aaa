"""RotorBearingPlant: the rotor on its fluid-film bearings, with a sigmoid oil-flow fault, as an FMU.

A thin FMI 2.0 co-simulation shell (pythonfmu) around ``oilwatch.models.system.plant.RotorBearingPlant``: it
declares the variables in the field's units, checks the parameters at initialization and maps them to SI, and
steps the plant. The plant integrates the full finite-element model with its own sub-stepped trapezoidal rule,
not with the estimator's discrete map, and starts in the steady orbit of its initial flowrates.

Fault: each bearing's supply flowrate follows ``q(t) = q_initial + (q_final - q_initial) /
(1 + exp(-(t - fault_time_s) / tau))`` with ``tau = fault_duration_s / (2 ln 9)``: ``fault_duration_s`` is
the 10 %-90 % transition time. ``flow_source = 1`` replaces the schedule with the inputs ``q1_in_ml_min``
and ``q2_in_ml_min`` (held over each communication step), so that an oil-system model can drive them.
Every flowrate and the speed default to 0, which stands for the machine file's nominal value (machine facts
live in the machine file, not in start values). The FMU limits the process's OpenBLAS threads to one when it
is instantiated (:mod:`oilwatch.fmu_src.blas_threads`).

Operating point: the inputs ``speed_hz`` and ``oil_temperature_c`` (held over each step; their values at
initialization are the start speed and oil temperature, 0 and -300 the machine's nominal ones) set the spin
speed and the oil supply temperature. With ``bearing_table = 1`` the bearings follow them through the
dimensionless table (the oil's ASTM D341 law times ``viscosity_factor`` gives the film viscosity), the
unbalance turns with the integral of the speed and the gyroscopic terms follow it; with ``bearing_table = 0``
(default: the estimator's own table, so that every earlier result stands) the flowrate table at the start
speed is used and both inputs must stay at their start values. Measurement chain
(``oilwatch.models.system.measurement``): probe mounting angle, per-probe zero offset, sensitivity error,
1x/2x runout and fault; an unbalance change at a given time; the true positions and each bearing's
eccentricity ratio and minimum film thickness are outputs. ``film_model =
"transient-film"`` replaces the linearized films by the transient p-theta films
(``oilwatch.models.system.nonlinear_plant``: high fidelity, about 10^3 times slower than real time).
Model structure (``oilwatch.models.system.structure``, the plant only): bearing clearance and length factors,
flexible pedestals, a shaft bow and the support-reaction load split.
"""

from __future__ import annotations

import dataclasses
import math

from pythonfmu import DefaultExperiment

from oilwatch.fmu_src.blas_threads import limit_blas_threads
from oilwatch.fmu_src.machine_parameters import (
    declare_machine_parameters,
    held_operating_point,
    machine_of,
    operating_conditions,
    probe_angle_deg,
    require_oil,
    rotor_bearing_system,
)
from oilwatch.fmu_src.slave_base import OilwatchSlave
from oilwatch.models.bearing.supply import ML_MIN_PER_M3_S
from oilwatch.models.system.fault import SigmoidFlowrate
from oilwatch.models.system.measurement import (
    FAULT_KINDS,
    PROBE_NAMES,
    MeasurementChain,
    ProbeErrors,
    UnbalanceChange,
)
from oilwatch.models.system.nonlinear_plant import FILM_MODELS, check_film_model, make_plant
from oilwatch.models.system.operating_point import operating_system
from oilwatch.models.system.plant import publish_initial_sample
from oilwatch.models.system.structure import PlantStructure, structural_system
from oilwatch.models.validation import (
    MAX_FLOWRATE_ML_MIN,
    MAX_PROBE_UM,
    MAX_SEED,
    MAX_UNBALANCE_G_MM,
    NEVER_S,
    PHASE_RANGE_DEG,
    InputError,
)

# Per-probe parameters: (suffix, ProbeErrors field, unit, SI per unit, minimum, maximum, description).
PROBE_PARAMETERS = (
    ("offset_um", "zero_offset_m", "um", 1e-6, -500.0, 500.0, "zero offset added to the reading"),
    ("sensitivity_error_pct", "sensitivity_error", "%", 1e-2, -50.0, 50.0,
     "scale-factor error: reading x (1 + error)"),
    ("runout_1x_um", "runout_1x_m", "um", 1e-6, 0.0, 100.0, "1x runout amplitude (shaft surface)"),
    ("runout_1x_phase_deg", "runout_1x_phase_rad", "deg", math.pi / 180, -360.0, 360.0,
     "1x runout phase from the keyphasor"),
    ("runout_2x_um", "runout_2x_m", "um", 1e-6, 0.0, 100.0, "2x runout amplitude"),
    ("runout_2x_phase_deg", "runout_2x_phase_rad", "deg", math.pi / 180, -360.0, 360.0,
     "2x runout phase from the keyphasor"),
    ("fault_time_s", "fault_time_s", "s", 1.0, 0.0, NEVER_S, "time the probe's fault starts"),
    ("glitch_um", "glitch_m", "um", 1e-6, -1000.0, 1000.0, "size of a glitch fault"),
    ("glitch_duration_s", "glitch_duration_s", "s", 1.0, 0.0, NEVER_S, "length of a glitch fault"),
)  # fmt: skip

# The plant's model-structure parameters: (FMU name, PlantStructure field, unit, SI per unit); the range and
# the description are the field's own (oilwatch.models.system.structure).
STRUCTURE_PARAMETERS = (
    ("clearance_factor", "clearance_factor", "1", 1.0),
    ("length_factor", "length_factor", "1", 1.0),
    ("pedestal_mass_kg", "pedestal_mass_kg", "kg", 1.0),
    ("pedestal_stiffness_n_m", "pedestal_stiffness_n_m", "N/m", 1.0),
    ("pedestal_damping_n_s_m", "pedestal_damping_n_s_m", "N.s/m", 1.0),
    ("bow_um", "bow_m", "um", 1e-6),
    ("bow_phase_deg", "bow_phase_rad", "deg", math.pi / 180),
    ("side_load_fraction", "side_load_fraction", "1", 1.0),
    ("side_load_angle_deg", "side_load_angle_deg", "deg", 1.0),
)

SAMPLING_PERIOD_S = 1e-3
WARM_UP_STEPS = 16
"""Steps taken and undone at the end of initialization (``_warm_up``): more than the few calls after
which CPython specialises a function's bytecode."""
OUTPUTS = ("x1", "y1", "x2", "y2")


class RotorBearingPlant(OilwatchSlave):
    """FMI slave of the rotor-bearing plant (see the module docstring)."""

    author = "oilwatch"
    description = (
        "Rotor on two fluid-film bearings (Timoshenko FE rotor, p-theta bearing tables) with a sigmoid "
        "supply-flowrate fault; outputs the shaft position in each bearing as proximity probes measure it"
    )
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=20.0, step_size=SAMPLING_PERIOD_S)
    state_attributes = ("plant_snapshot",)

    def __init__(self, **kwargs):
        limit_blas_threads()
        super().__init__(**kwargs)
        self.plant = None
        self._nominal_ml_min = None  # each bearing's, from the machine at setup
        real = self.declare_real
        declare_machine_parameters(self)
        self._declare_operating_point()
        self._declare_measurement_chain()
        self._declare_structure()
        self.declare_string(
            "film_model",
            "parameter",
            start=FILM_MODELS[0],
            description=f"Films of the truth: {' or '.join(FILM_MODELS)} (rotor on transient p-theta films, "
            "nominal speed and unbalance only, about 10^3 times slower than real time)",
        )
        for b in (1, 2):
            for stage, text in (("initial", "before"), ("final", "after")):
                real(
                    f"q{b}_{stage}_ml_min",
                    "parameter",
                    start=0.0,
                    unit="ml/min",
                    minimum=0.0,
                    maximum=MAX_FLOWRATE_ML_MIN,
                    description=f"Supply flowrate of bearing {b} {text} the fault (sigmoid schedule); 0: the "
                    f"machine file's nominal flowrate of bearing {b}",
                )
        real(
            "fault_time_s",
            "parameter",
            start=10.0,
            unit="s",
            minimum=-NEVER_S,
            maximum=NEVER_S,
            description="Centre of the sigmoid flowrate transition (half the change done)",
        )
        real(
            "fault_duration_s",
            "parameter",
            start=0.1,
            unit="s",
            minimum=1e-6,
            maximum=NEVER_S,
            description="10 %-90 % transition time of the sigmoid",
        )
        real(
            "noise_um",
            "parameter",
            start=1.0,
            unit="um",
            minimum=0.0,
            maximum=MAX_PROBE_UM,
            description="Std of the white measurement noise added to each probe",
        )
        self.declare_integer(
            "seed",
            "parameter",
            start=1,
            minimum=0,
            maximum=MAX_SEED,
            description="Seed of the measurement-noise generator",
        )
        self.declare_integer(
            "flow_source",
            "parameter",
            start=0,
            minimum=0,
            maximum=1,
            description="0: sigmoid fault schedule; 1: flowrates from q1_in_ml_min, q2_in_ml_min",
        )
        for b in (1, 2):
            real(
                f"q{b}_in_ml_min",
                "input",
                start=0.0,
                unit="ml/min",
                minimum=0.0,
                maximum=MAX_FLOWRATE_ML_MIN,
                description=f"Supply flowrate of bearing {b} when flow_source = 1; 0: the machine file's "
                f"nominal flowrate of bearing {b}",
            )
        for name in OUTPUTS:
            axis, b = name[0], name[1]
            real(
                f"{name}_um",
                "output",
                start=0.0,
                unit="um",
                description=f"Measured {axis} position of the shaft in bearing {b} (true + noise)",
            )
        for name in OUTPUTS:
            axis, b = name[0], name[1]
            real(
                f"{name}_true_um",
                "output",
                start=0.0,
                unit="um",
                description=f"True {axis} position of the shaft in bearing {b}, from the bearing centre",
            )
        real(
            "t_sample_s",
            "output",
            start=0.0,
            unit="s",
            description="Time the position outputs refer to (the end of the last step); an estimator uses it "
            "to stay aligned whatever the master's ordering",
        )
        for b in (1, 2):
            real(
                f"eccentricity_ratio{b}",
                "output",
                start=0.0,
                unit="1",
                description=f"Eccentricity ratio of the journal in bearing {b} (true position / clearance)",
            )
            real(
                f"h_min{b}_um",
                "output",
                start=0.0,
                unit="um",
                description=f"Minimum film thickness in bearing {b}, c (1 - eccentricity ratio)",
            )
        real(
            "rotor_angle_deg",
            "output",
            start=0.0,
            unit="deg",
            description="Rotor angle from the keyphasor mark (integral of the speed), modulo 360",
        )
        for b in (1, 2):
            real(
                f"q{b}_ml_min",
                "output",
                start=0.0,
                unit="ml/min",
                description=f"True supply flowrate of bearing {b}",
            )

    def _declare_operating_point(self) -> None:
        real = self.declare_real
        real(
            "viscosity_factor",
            "parameter",
            start=1.0,
            unit="1",
            minimum=0.2,
            maximum=5.0,
            description="Film viscosity over the oil's law at the oil temperature (film heating, model)",
        )
        real(
            "unbalance_change_time_s",
            "parameter",
            start=1e9,
            unit="s",
            minimum=0.0,
            maximum=NEVER_S,
            description="Time of a sudden unbalance change (a blade loss), from the first step at or after",
        )
        real(
            "unbalance_change_g_mm",
            "parameter",
            start=0.0,
            unit="g.mm",
            minimum=0.0,
            maximum=MAX_UNBALANCE_G_MM,
            description="Unbalance moment after the change",
        )
        real(
            "unbalance_change_phase_deg",
            "parameter",
            start=0.0,
            unit="deg",
            minimum=PHASE_RANGE_DEG[0],
            maximum=PHASE_RANGE_DEG[1],
            description="Unbalance phase after the change",
        )

    def _declare_structure(self) -> None:
        """The plant's structure where it differs from the machine file (the estimator's model)."""
        metadata = {f.name: f.metadata for f in dataclasses.fields(PlantStructure)}
        for name, field, unit, si in STRUCTURE_PARAMETERS:
            low, high = metadata[field]["range"]
            self.declare_real(
                name,
                "parameter",
                start=getattr(PlantStructure(), field) / si,
                unit=unit,
                minimum=low / si,
                maximum=high / si,
                description=f"Plant only (the estimator keeps the machine file's): "
                f"{metadata[field]['description']}",
            )
        self.declare_integer(
            "load_split_reactions",
            "parameter",
            start=0,
            minimum=0,
            maximum=1,
            description="Plant only: 0 the machine file's bearing load split, 1 the support reactions",
        )
        self.declare_integer(
            "threshold_one_sided",
            "parameter",
            start=0,
            minimum=0,
            maximum=1,
            description="Plant only: 1 the film coefficients' one-sided limits at each flooded threshold "
            "(the jump a direct solve has; needs length_factor 1), 0 interpolated across it as the estimator "
            "does",
        )

    def _structure(self) -> PlantStructure:
        values = {field: getattr(self, name) * si for name, field, _, si in STRUCTURE_PARAMETERS}
        return PlantStructure(
            **values,
            load_split="reactions" if self.load_split_reactions else None,
            threshold_one_sided=bool(self.threshold_one_sided),
        )

    def _declare_measurement_chain(self) -> None:
        for probe in PROBE_NAMES:
            for suffix, _, unit, _, low, high, text in PROBE_PARAMETERS:
                start = 1e9 if suffix == "fault_time_s" else 0.0
                self.declare_real(
                    f"{probe}_{suffix}",
                    "parameter",
                    start=start,
                    unit=unit,
                    minimum=low,
                    maximum=high,
                    description=f"Probe {probe}: {text}",
                )
            self.declare_integer(
                f"{probe}_fault",
                "parameter",
                start=0,
                minimum=0,
                maximum=len(FAULT_KINDS) - 1,
                description=f"Probe {probe} fault from {probe}_fault_time_s: 0 none, 1 dead (NaN), "
                "2 stuck at its last value, 3 glitch",
            )

    def _chain(self, machine) -> MeasurementChain:
        probes = []
        for probe in PROBE_NAMES:
            values = {
                field: getattr(self, f"{probe}_{suffix}") * si
                for suffix, field, _, si, *_ in PROBE_PARAMETERS
            }
            probes.append(ProbeErrors(**values, fault=FAULT_KINDS[getattr(self, f"{probe}_fault")]))
        angle = math.remainder(probe_angle_deg(self, machine), 360.0)  # the chain takes [-180, 180] deg
        return MeasurementChain(tuple(probes), math.radians(angle))

    def _conditions(self, machine) -> tuple[float, float | None]:
        """(speed [Hz], oil temperature [degC] or None without an oil) from the inputs."""
        return operating_conditions(self, machine)

    def _system(self, machine):
        structure = self._structure()
        if structure != PlantStructure():
            return self._structural_system(machine, structure)
        if self.bearing_table == 0:
            return rotor_bearing_system(
                self.machine_file,
                self.resources,
                self.speed_hz,
                self.unbalance_g_mm,
                self.unbalance_phase_deg,
                reduced=False,
            )
        speed, temperature = self._conditions(machine)
        viscosity = self.viscosity_factor * machine.oil.dynamic_viscosity_pa_s(temperature)
        return operating_system(
            machine,
            speed,
            viscosity,
            unbalance_moment_kg_m=None if self.unbalance_g_mm < 0.0 else self.unbalance_g_mm * 1e-6,
            unbalance_phase_rad=math.radians(self.unbalance_phase_deg),
        )

    def _structural_system(self, machine, structure: PlantStructure):
        """The plant with a model-structure discrepancy: at the machine's nominal speed and oil temperature
        (with ``bearing_table = 1`` the speed and temperature inputs then move it)."""
        if self.film_model != FILM_MODELS[0]:
            raise InputError(f"film_model = {self.film_model} has the machine file's structure only")
        speed, _ = self._conditions(machine)
        if self.bearing_table == 0 and abs(speed - machine.nominal_speed_hz) > 1e-9 * speed:
            raise InputError(
                f"speed_hz = {speed:g} Hz: the structure parameters with bearing_table = 0 run at the "
                f"machine's "
                f"nominal speed {machine.nominal_speed_hz:g} Hz (bearing_table = 1 follows the speed)"
            )
        moment = None if self.unbalance_g_mm < 0.0 else self.unbalance_g_mm * 1e-6
        return structural_system(machine, structure, moment, math.radians(self.unbalance_phase_deg))

    @property
    def plant_snapshot(self):
        """The plant's full state (for fmi2GetFMUstate / fmi2SetFMUstate)."""
        return None if self.plant is None else self.plant.snapshot()

    @plant_snapshot.setter
    def plant_snapshot(self, snapshot) -> None:
        if snapshot is not None:
            self.plant.restore(snapshot)

    def validate_parameters(self) -> None:
        check_film_model(self.film_model)

    def _flowrate_m3_s(self, bearing: int, name: str) -> float:
        """A flowrate variable [ml/min] of ``bearing`` (1 or 2) in m^3/s; 0 stands for that bearing's nominal
        flowrate in the machine file. NaN or a negative value is refused (InputError naming it), never
        replaced."""
        value = getattr(self, name)
        if not 0.0 <= value <= MAX_FLOWRATE_ML_MIN:
            raise InputError(
                f"{name} must be a flowrate in [0, {MAX_FLOWRATE_ML_MIN:g}] ml/min (0: the machine's "
                f"nominal), got {value!r}"
            )
        return (value if value > 0.0 else self._nominal_ml_min[bearing - 1]) / ML_MIN_PER_M3_S

    def _inputs_m3_s(self) -> tuple[float, float]:
        return (self._flowrate_m3_s(1, "q1_in_ml_min"), self._flowrate_m3_s(2, "q2_in_ml_min"))

    def setup(self) -> None:
        machine = machine_of(self.machine_file, self.resources)
        self._machine = machine
        require_oil(self, machine)
        system = self._system(machine)
        self._start_conditions = self._conditions(machine)
        self._nominal_ml_min = system.nominal_flowrates_m3_s * ML_MIN_PER_M3_S
        schedules = None
        if self.flow_source == 0:
            ignored = [f"q{b}_in_ml_min" for b in (1, 2) if getattr(self, f"q{b}_in_ml_min") != 0.0]
            if ignored:  # refused, not ignored: the schedule would drive the flowrates
                raise InputError(
                    f"{ignored[0]} = {getattr(self, ignored[0])!r} is ignored while flow_source = 0 (the "
                    "sigmoid schedule drives the flowrates): set flow_source = 1 or leave it at 0"
                )
            schedules = tuple(
                SigmoidFlowrate(
                    self._flowrate_m3_s(b, f"q{b}_initial_ml_min"),
                    self._flowrate_m3_s(b, f"q{b}_final_ml_min"),
                    self.fault_time_s,
                    self.fault_duration_s,
                )
                for b in (1, 2)
            )
        inputs = self._inputs_m3_s()
        try:
            self.plant = make_plant(
                self.film_model,
                system,
                machine,
                SAMPLING_PERIOD_S,
                schedules,
                self.noise_um * 1e-6,
                self.seed,
                initial_flowrates_m3_s=inputs,
                start_time_s=self.start_time,
                chain=self._chain(machine),
                unbalance_change=UnbalanceChange(
                    self.unbalance_change_time_s,
                    self.unbalance_change_g_mm * 1e-6,
                    math.radians(self.unbalance_change_phase_deg),
                ),
                oil=machine.oil if self.bearing_table == 1 else None,
                oil_temperature_c=self._start_conditions[1] if self.bearing_table == 1 else None,
                viscosity_factor=self.viscosity_factor if self.bearing_table == 1 else 1.0,
            )
        except InputError as error:
            raise InputError(_fmu_names(str(error))) from None
        initial = publish_initial_sample(self.plant)
        self._warm_up()
        self._publish(initial)

    def _warm_up(self) -> None:
        """Take :data:`WARM_UP_STEPS` steps and return to the state before them, so that the first doStep
        costs what the later ones do: the first runs of the step's code (the integrator's and the
        measurement's arrays touched, the compiled kernels' first calls, the interpreter's specialisation
        of the step's Python after its first few calls) happen in initialization. An error of a step is
        left to the first doStep, which reports it."""
        snapshot = self.plant.snapshot()
        try:
            for k in range(WARM_UP_STEPS):
                self.step(self.start_time + k * self.plant.dt_s, self.plant.dt_s)
        except Exception:  # the same step runs again at the first doStep, which reports it
            pass
        self.plant.restore(snapshot)

    def step(self, current_time: float, step_size: float) -> bool:
        if abs(step_size - self.plant.dt_s) > 1e-12 * step_size:
            self.plant.set_period(step_size)
        inputs = self._inputs_m3_s() if self.flow_source == 1 else None
        conditions = held_operating_point(self, self._machine, self._start_conditions)
        if self.bearing_table == 0:
            self._publish(self.plant.step(inputs))
        else:
            self._publish(self.plant.step(inputs, speed_hz=conditions[0], oil_temperature_c=conditions[1]))
        return True

    def _publish(self, sample) -> None:
        for name, measured, true in zip(
            OUTPUTS, sample.measured_position_m, sample.true_position_m, strict=True
        ):
            setattr(self, f"{name}_um", measured * 1e6)
            setattr(self, f"{name}_true_um", true * 1e6)
        for b in (1, 2):
            setattr(self, f"eccentricity_ratio{b}", float(sample.eccentricity_ratio[b - 1]))
            setattr(self, f"h_min{b}_um", float(sample.min_film_thickness_m[b - 1]) * 1e6)
        self.rotor_angle_deg = math.degrees(self.plant.rotor_angle_rad) % 360.0
        self.t_sample_s = self.plant.time_s
        self.q1_ml_min = sample.flowrate_m3_s[0] * ML_MIN_PER_M3_S
        self.q2_ml_min = sample.flowrate_m3_s[1] * ML_MIN_PER_M3_S


def _fmu_names(message: str) -> str:
    """Name the FMU's parameters in a model-level message."""
    for b in (1, 2):
        message = message.replace(f"q{b} initial", f"q{b}_initial_ml_min")
        message = message.replace(f"q{b} final", f"q{b}_final_ml_min")
        message = message.replace(f"q{b} input", f"q{b}_in_ml_min")
    return message
