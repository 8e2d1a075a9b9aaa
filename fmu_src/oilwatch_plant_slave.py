"""RotorBearingPlant: the rotor on its fluid-film bearings, with a sigmoid oil-flow fault, as an FMU.

A thin FMI 2.0 co-simulation shell (pythonfmu) around ``models.system.plant.RotorBearingPlant``: it declares
the variables in the field's units, checks the parameters at initialization and maps them to SI, and steps
the plant. The plant integrates the full finite-element model with its own sub-stepped trapezoidal rule,
not with the estimator's discrete map, and starts in the steady orbit of its initial flowrates.

Fault: each bearing's supply flowrate follows ``q(t) = q_initial + (q_final - q_initial) /
(1 + exp(-(t - fault_time_s) / tau))`` with ``tau = fault_duration_s / (2 ln 9)``: ``fault_duration_s`` is
the 10 %-90 % transition time. ``flow_source = 1`` replaces the schedule with the inputs ``q1_in_ml_min``
and ``q2_in_ml_min`` (held over each communication step), so that an oil-system model can drive them.
Every flowrate and the speed default to 0, which stands for the machine file's nominal value (machine facts
live in the machine file, not in start values). The FMU limits the process's OpenBLAS threads to one when it
is instantiated (:mod:`fmu_src.blas_threads`).
"""

from __future__ import annotations

from pythonfmu import DefaultExperiment

from fmu_src.blas_threads import limit_blas_threads
from fmu_src.machine_parameters import declare_machine_parameters, rotor_bearing_system
from fmu_src.slave_base import OilwatchSlave
from models.bearing.supply import ML_MIN_PER_M3_S
from models.system.fault import SigmoidFlowrate
from models.system.plant import RotorBearingPlant as PlantModel
from models.validation import InputError

SAMPLING_PERIOD_S = 1e-3
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
        self._nominal_ml_min = None
        real = self.declare_real
        declare_machine_parameters(self)
        for b in (1, 2):
            for stage, text in (("initial", "before"), ("final", "after")):
                real(
                    f"q{b}_{stage}_ml_min",
                    "parameter",
                    start=0.0,
                    unit="ml/min",
                    minimum=0.0,
                    description=f"Supply flowrate of bearing {b} {text} the fault (sigmoid schedule); 0: the "
                    "machine file's nominal flowrate",
                )
        real(
            "fault_time_s",
            "parameter",
            start=10.0,
            unit="s",
            description="Centre of the sigmoid flowrate transition (half the change done)",
        )
        real(
            "fault_duration_s",
            "parameter",
            start=0.1,
            unit="s",
            minimum=1e-6,
            description="10 %-90 % transition time of the sigmoid",
        )
        real(
            "noise_um",
            "parameter",
            start=1.0,
            unit="um",
            minimum=0.0,
            description="Std of the white measurement noise added to each probe",
        )
        self.declare_integer(
            "seed", "parameter", start=1, minimum=0, description="Seed of the measurement-noise generator"
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
                description=f"Supply flowrate of bearing {b} when flow_source = 1; 0: the machine file's "
                "nominal flowrate",
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
                f"q{b}_ml_min",
                "output",
                start=0.0,
                unit="ml/min",
                description=f"True supply flowrate of bearing {b}",
            )

    @property
    def plant_snapshot(self):
        """The plant's full state (for fmi2GetFMUstate / fmi2SetFMUstate)."""
        return None if self.plant is None else self.plant.snapshot()

    @plant_snapshot.setter
    def plant_snapshot(self, snapshot) -> None:
        if snapshot is not None:
            self.plant.restore(snapshot)

    def _flowrate_m3_s(self, name: str) -> float:
        """A flowrate variable [ml/min] in m^3/s; 0 stands for the machine's nominal flowrate."""
        value = getattr(self, name)
        return (value if value > 0.0 else self._nominal_ml_min) / ML_MIN_PER_M3_S

    def _inputs_m3_s(self) -> tuple[float, float]:
        return (self._flowrate_m3_s("q1_in_ml_min"), self._flowrate_m3_s("q2_in_ml_min"))

    def setup(self) -> None:
        system = rotor_bearing_system(
            self.machine_file,
            self.resources,
            self.speed_hz,
            self.unbalance_g_mm,
            self.unbalance_phase_deg,
            reduced=False,
        )
        self._nominal_ml_min = system.nominal_flowrate_m3_s * ML_MIN_PER_M3_S
        schedules = None
        if self.flow_source == 0:
            schedules = tuple(
                SigmoidFlowrate(
                    self._flowrate_m3_s(f"q{b}_initial_ml_min"),
                    self._flowrate_m3_s(f"q{b}_final_ml_min"),
                    self.fault_time_s,
                    self.fault_duration_s,
                )
                for b in (1, 2)
            )
        inputs = self._inputs_m3_s()
        try:
            self.plant = PlantModel(
                system,
                SAMPLING_PERIOD_S,
                schedules,
                self.noise_um * 1e-6,
                self.seed,
                initial_flowrates_m3_s=inputs,
                start_time_s=self.start_time,
            )
        except InputError as error:
            raise InputError(_fmu_names(str(error))) from None
        self._publish(self.plant.current_sample())

    def step(self, current_time: float, step_size: float) -> bool:
        if abs(step_size - self.plant.dt_s) > 1e-12 * step_size:
            self.plant.set_period(step_size)
        inputs = self._inputs_m3_s() if self.flow_source == 1 else None
        self._publish(self.plant.step(inputs))
        return True

    def _publish(self, sample) -> None:
        for name, measured, true in zip(
            OUTPUTS, sample.measured_position_m, sample.true_position_m, strict=True
        ):
            setattr(self, f"{name}_um", measured * 1e6)
            setattr(self, f"{name}_true_um", true * 1e6)
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
