"""BareFilter: an FMU with the OilFlowEKF FMU's inputs and the outputs the benchmark reads, whose doStep does
nothing: the cost of pythonfmu's own calls (``benchmarks/ekf_step.py``)."""

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.enums import Fmi2Initial


class BareFilter(Fmi2Slave):
    """Inputs x1_um .. y2_um, speed_hz, oil_temperature_c; outputs q1/q2 estimates and stds, four flags."""

    author = "oilwatch"
    description = "Does nothing: the baseline of pythonfmu's call overhead"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for name in ("x1_um", "y1_um", "x2_um", "y2_um", "speed_hz", "oil_temperature_c"):
            setattr(self, name, 0.0)
            self.register_variable(Real(name, causality=Fmi2Causality.input, start=0.0))
        for name in ("q1_est_ml_min", "q2_est_ml_min", "q1_std_ml_min", "q2_std_ml_min"):
            setattr(self, name, 0.0)
            self.register_variable(
                Real(name, causality=Fmi2Causality.output, initial=Fmi2Initial.exact, start=0.0)
            )
        for name in ("starved1", "starved2", "converged", "measurement_ok"):
            setattr(self, name, False)
            self.register_variable(
                Boolean(
                    name,
                    causality=Fmi2Causality.output,
                    variability=Fmi2Variability.discrete,
                    initial=Fmi2Initial.exact,
                    start=False,
                )
            )

    def do_step(self, current_time: float, step_size: float) -> bool:
        return True
