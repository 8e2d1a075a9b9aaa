"""FMI 3.0 co-simulation shells (pythonfmu3) around the FMI 2.0 slaves: one definition of each FMU.

An FMI 3.0 slave here declares nothing of its own. :class:`Fmi3Shell` creates the FMI 2.0 slave named by
:attr:`Fmi3Shell.fmi2_slave` (an :class:`oilwatch.fmu_src.slave_base.OilwatchSlave`) as a plain Python object
and exposes its declared variables as FMI 3.0 variables (Real -> Float64 with the same unit, min, max, start
and description; Integer -> Int32; Boolean; String), in the same order, and its unit definitions,
model description, author and default experiment. Every FMI 3.0 call goes to that object: initialization
(the same parameter checks and messages), ``do_step``, the full state (``_get_fmu_state`` with the
covariance and the random generator, pickled by ``_fmu_state_to_bytes``). The FMI 2.0 slave's log messages are
re-logged through the shell, so its messages reach the FMI 3.0 host's logger (the status codes 0..4
coincide; pythonfmu's own LogMsg cannot be passed on: pythonfmu3's C++ side reads a ``debug`` field that it
lacks, and crashes on the missing attribute).

What pythonfmu3 0.3.4 cannot carry over, and what this does about it:

- Its variables write no ``min``/``max``: :class:`RangedFloat64` and :class:`RangedInt32` add them.
- Its ``fmi3EnterInitializationMode`` passes only the start time to Python (``setup_experiment(start)``);
  the stop time is dropped. The oilwatch slaves use only the start time.
- Its ``fmi3DoStep`` reports no early return or event; the slaves need neither.
- Any Python exception is fmi3Fatal. The FMU's binary is a layer over pythonfmu3's
  (``oilwatch/cosim/native/fmi3_refusal.c``) that returns fmi3Error when the slave refused the user's input
  (a parameter out of range at fmi3ExitInitializationMode, a fixed parameter set after it: refused here as
  in FMI 2.0), as ``fmu_src/slave_base.py`` does with the FMI 2.0 loader.
"""

from __future__ import annotations

from typing import Any, ClassVar

from pythonfmu3 import Fmi3Slave
from pythonfmu3.default_experiment import DefaultExperiment
from pythonfmu3.enums import Fmi3Causality, Fmi3Initial, Fmi3Status, Fmi3Variability
from pythonfmu3.unit import Unit
from pythonfmu3.variables import Boolean, Float64, Int32, String

from .fmi_variables import UNITS, DescribedBoolean, DescribedString, RangedInteger, UnitReal
from .slave_base import OilwatchSlave


class RangeMixin:
    """Gives a pythonfmu3 variable class ``minimum``/``maximum`` (None: unbounded), written as ``min`` and
    ``max`` before ``start`` (the FMI 3.0 attribute order)."""

    def __init__(self, name: str, *, minimum=None, maximum=None, **kwargs):
        super().__init__(name, **kwargs)
        self.minimum, self.maximum = minimum, maximum

    def to_xml(self):
        element = super().to_xml()
        extra = {}
        for key, value in (("min", self.minimum), ("max", self.maximum)):
            if value is not None:
                extra[key] = f"{value:.16g}" if isinstance(value, float) else str(int(value))
        if extra:
            attrib = dict(element.attrib)
            start = attrib.pop("start", None)
            element.attrib.clear()
            element.attrib.update(attrib | extra | ({"start": start} if start is not None else {}))
        return element


class RangedFloat64(RangeMixin, Float64):
    """A pythonfmu3 ``Float64`` with ``min`` and ``max``."""


class RangedInt32(RangeMixin, Int32):
    """A pythonfmu3 ``Int32`` with ``min`` and ``max``."""


def _fmi3_variable(variable, owner: OilwatchSlave):
    """The FMI 3.0 twin of one declared FMI 2.0 variable, reading and writing ``owner``'s attribute."""
    name, reference = variable.local_name, (variable.value_reference,)

    def getter():
        owner.refresh_outputs(reference)  # the EKF's lazy outputs publish the last step's report when read
        return getattr(owner, name)

    common = {
        "causality": Fmi3Causality[variable.causality.name],
        "variability": Fmi3Variability[variable.variability.name],
        "initial": Fmi3Initial[variable.initial.name] if variable.initial is not None else None,
        "description": variable.description,
        "getter": getter,
        "setter": lambda value: setattr(owner, name, value),
    }
    start = getattr(owner, name)
    if isinstance(variable, UnitReal):
        return RangedFloat64(
            variable.name,
            start=start,
            unit=variable.unit,
            minimum=variable.minimum,
            maximum=variable.maximum,
            **common,
        )
    if isinstance(variable, RangedInteger):
        return RangedInt32(
            variable.name, start=start, minimum=variable.minimum, maximum=variable.maximum, **common
        )
    if isinstance(variable, DescribedBoolean):
        return Boolean(variable.name, start=start, **common)
    if isinstance(variable, DescribedString):
        return String(variable.name, start=start, **common)
    raise TypeError(f"variable {variable.name}: no FMI 3.0 counterpart for {type(variable).__name__}")


class Fmi3Shell(Fmi3Slave):
    """Base of the FMI 3.0 slaves: a pythonfmu3 facade over one FMI 2.0 oilwatch slave (module docstring)."""

    #: The FMI 2.0 slave class whose variables and behaviour this FMU exposes.
    fmi2_slave: ClassVar[type[OilwatchSlave]]

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        slave_class = self.fmi2_slave
        self.slave = slave_class(
            instance_name=kwargs["instance_name"],
            resources=kwargs.get("resources"),
            visible=kwargs.get("visible", False),
        )
        self.slave.log = self._log_from_fmi2_slave
        self.slave.initialization_end_call = "fmi3ExitInitializationMode"
        self.slave.fmi_facade = self
        self.author = slave_class.author
        self.description = slave_class.description
        experiment = slave_class.default_experiment
        if experiment is not None:
            self.default_experiment = DefaultExperiment(
                start_time=experiment.start_time,
                stop_time=experiment.stop_time,
                step_size=experiment.step_size,
                tolerance=experiment.tolerance,
            )
        for variable in self.slave.declared_variables:
            self.register_variable(_fmi3_variable(variable, self.slave))
        # FMI 3.0 wants exactly one independent variable; registered last, so that every value reference is
        # the FMI 2.0 FMU's
        self.time = 0.0
        self.register_variable(
            Float64(
                "time",
                causality=Fmi3Causality.independent,
                variability=Fmi3Variability.continuous,
                unit="s",
                description="Simulation time",
            )
        )
        units = {v.unit for v in self.slave.declared_variables if getattr(v, "unit", None)}
        for unit in sorted({"s"} | units):
            definition = UNITS[unit]
            # the FMI 2.0 description writes 16 significant digits: the same numbers here
            factor, offset = (float(f"{x:.16g}") for x in (definition.factor, definition.offset))
            self.units[unit] = Unit(unit, factor=factor, offset=offset, **definition.exponents)

    def _log_from_fmi2_slave(self, msg: str, status=0, category=None, debug=None) -> None:
        # pythonfmu3's C++ side reads LogMsg.debug, which pythonfmu's LogMsg lacks: re-log as FMI 3.0
        self.log(msg, Fmi3Status(int(status)), category)

    # ------------------------------------------------------------------ behaviour
    def setup_experiment(self, start_time: float):
        self.time = float(start_time)
        self.slave.setup_experiment(start_time)

    def enter_initialization_mode(self):
        self.slave.enter_initialization_mode()

    def exit_initialization_mode(self):
        self.slave.exit_initialization_mode()

    def do_step(self, current_time: float, step_size: float) -> bool:
        done = self.slave.do_step(current_time, step_size)
        self.time = current_time + step_size
        return done

    def terminate(self):
        self.slave.terminate()

    # a fixed parameter set after initialization is refused as in FMI 2.0 (fmi3Error through the binary's
    # layer, oilwatch/cosim/native/fmi3_refusal.c)
    def set_float64(self, vrs, values):
        self.slave.refuse_fixed_after_initialization(vrs, values, "fmi3SetFloat64")
        super().set_float64(vrs, values)

    def set_int32(self, vrs, values):
        self.slave.refuse_fixed_after_initialization(vrs, values, "fmi3SetInt32")
        super().set_int32(vrs, values)

    def set_boolean(self, vrs, values):
        self.slave.refuse_fixed_after_initialization(vrs, values, "fmi3SetBoolean")
        super().set_boolean(vrs, values)

    def set_string(self, vrs, values):
        self.slave.refuse_fixed_after_initialization(vrs, values, "fmi3SetString")
        super().set_string(vrs, values)

    # ---------------------------------------------------------------------- state
    def _get_fmu_state(self) -> dict[str, Any]:
        return self.slave._get_fmu_state()

    def _set_fmu_state(self, state: dict[str, Any]):
        self.slave._set_fmu_state(state)

    @staticmethod
    def _fmu_state_to_bytes(state: dict[str, Any]) -> bytes:
        return OilwatchSlave._fmu_state_to_bytes(state)

    @staticmethod
    def _fmu_state_from_bytes(state: bytes) -> dict[str, Any]:
        return OilwatchSlave._fmu_state_from_bytes(state)
