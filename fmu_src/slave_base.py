"""A pythonfmu slave base class: declared variables with units, checked parameters, full state.

What pythonfmu 0.7.0 does, and what this class does about it (verified with fmpy 0.3.32):

- A Python exception in any slave method makes its C++ wrapper return ``fmi2Fatal`` and log
  ``Fatal py exception encountered: [exitInitializationMode] PyObject_CallMethod`` plus the
  exception's repr. If the slave queued log messages during the same call, the repr is lost and the
  line reads ``unknown error``. So this class logs every failure itself (status ``error``, category
  ``logStatusError``) before raising: the host always sees a message that names the parameter.
  After the fatal status, ``fmi2FreeInstance`` and ``fmi2Reset`` still work with pythonfmu; the FMI
  standard allows neither after ``fmi2Fatal``, so a careful host calls nothing more.
- ``do_step`` returning False gives ``fmi2Discard``.
- A fixed (non-tunable) parameter set after ``fmi2ExitInitializationMode`` is an error (FMI 2.0,
  section 4.2.4: fixed parameters may be set only before initialization ends); pythonfmu would store it
  and the model would silently ignore it. This class refuses it: the value is not stored, a message
  naming the parameter is logged at status error, and the call fails.
- A refused input is ``fmi2Error``, not ``fmi2Fatal``: the refused late set above, and an initialization
  that fails on the user's input (a parameter out of range, an ``InputError`` of validation or set-up,
  e.g. an unreadable ``baseline_file``). FMI 2.0 keeps ``fmi2Fatal`` for "all instances corrupted";
  here only this instance's parameters were wrong. pythonfmu 0.7's C++ wrapper maps every Python
  exception to ``fmi2Fatal`` (``handle_py_exception`` throws its ``fatal_error``) and ignores the return
  values, so ``fmi2Error`` cannot be returned from Python. Before raising, the slave therefore flags the
  refusal to oilwatch's FMI 2.0 loader, the FMU's own binary (``oilwatch/cosim/native/fmi2_loader.c``,
  entry point ``oilwatch_loader_refused_call``): the loader returns ``fmi2Error`` for that call (a
  refused set: the instance keeps stepping). Any other exception (an internal error) stays fatal. The FMI
  3.0 shells' binary has the same entry point (``native/fmi3_refusal.c``: fmi3Error). Without either (a
  plain pythonfmu build) the host still sees ``fmi2Fatal`` with the logged reason.
- The Get/Set calls are the per-step cost of a host (the estimator FMU's step must stay within its real-time
budget), so they   avoid pythonfmu's per-variable work: each type's variables sit in a dict by value reference
(pythonfmu   checks ``isinstance`` per variable and call), a declared variable's default getter and setter are
  ``functools.partial(getattr/setattr, self, name)`` (no Python frame), and the fixed parameters are one set
  checked only after initialization (``isdisjoint``, not a scan of the call's variables).
- The fast path. A subclass names its per-step real inputs in :attr:`OilwatchSlave.buffered_inputs`
  and the outputs it publishes with every step in :attr:`OilwatchSlave.buffered_outputs`. Their values live in
  two numpy arrays (``_inputs``, ``_outputs``; the attributes of those names read and write them), and at the
  end of initialization the slave hands both, a table by value reference and :meth:`_fast_step` to oilwatch's
  FMI 2.0 loader (entry point ``oilwatch_loader_bind_buffers``). The loader then serves setReal of those
  inputs and the Get calls of those variables in C and calls :meth:`_fast_step` for fmi2DoStep; every other
  call, and any call naming another variable, still comes here through pythonfmu. A step that does not simply
  succeed (it failed, discards or logged) is replayed through pythonfmu's doStep without running twice
  (:meth:`do_step`), so the host sees exactly pythonfmu's status and messages. ``OILWATCH_FMU_FAST_PATH=0``
  keeps every call on the Python path (the same values: the arrays are the storage either way).
- ``fmi2GetFMUstate`` returns whatever ``_get_fmu_state`` returns (a Python object held by
  reference; the default saves registered variables only). Here the state also holds deep copies of
  the attributes named in :attr:`OilwatchSlave.state_attributes` (numpy arrays, a
  ``numpy.random.Generator``), copied again on restore so that one saved state can be restored any
  number of times. Serialization uses pickle instead of pythonfmu's JSON (arrays are not JSON).

Subclasses declare variables in ``__init__`` with :meth:`declare_real` and friends, check their
parameters in :meth:`validate_parameters` (raise ``InputError``) and build their model in
:meth:`setup`; both run in ``exit_initialization_mode``.
"""

from __future__ import annotations

import copy
import math
import pickle
import traceback
from functools import partial
from typing import Any, ClassVar
from xml.etree.ElementTree import Element

import numpy as np
from pythonfmu import Fmi2Slave
from pythonfmu.enums import Fmi2Causality, Fmi2Status, Fmi2Variability
from pythonfmu.variables import Boolean, Integer, Real, String

from oilwatch.models.validation import InputError

from .fmi_variables import (
    DescribedBoolean,
    DescribedString,
    RangedInteger,
    UnitReal,
    unit_definitions_xml,
    variable_attributes,
)
from .loader_link import (
    STEP_DONE,
    STEP_REPLAY,
    bind_buffers,
    flag_refused_call_to_loader,
    outlive_the_wrappers_cleanup,
)


def buffered_property(buffer: str, index: int, convert) -> property:
    """The attribute of a buffered variable (module docstring: the fast path): element ``index`` of the
    slave's array ``buffer``."""

    def read(self):
        return convert(getattr(self, buffer).item(index))

    def write(self, value) -> None:
        getattr(self, buffer)[index] = value

    return property(read, write)


class SlaveInitializationError(RuntimeError):
    """Raised out of ``exit_initialization_mode`` (or a refused set) after the reasons were logged."""


VARIABLE_TYPES = (Real, Integer, Boolean, String)
"""pythonfmu's variable types, each with its Get/Set calls."""


class OilwatchSlave(Fmi2Slave):
    """Base class of the oilwatch FMI 2.0 co-simulation slaves (see the module docstring)."""

    #: Names of attributes (beyond registered variables) saved by fmi2GetFMUstate.
    state_attributes: ClassVar[tuple[str, ...]] = ()
    #: Real inputs and outputs (Real, Integer, Boolean) kept in the fast path's arrays (module docstring).
    buffered_inputs: ClassVar[tuple[str, ...]] = ()
    buffered_outputs: ClassVar[tuple[str, ...]] = ()
    #: The FMI call that ends initialization, in messages (the FMI 3.0 shell names its own).
    initialization_end_call = "fmi2ExitInitializationMode"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fmi_facade = self  # the object the FMI wrapper holds (the FMI 3.0 shell when it wraps it)
        self._declared: list = []
        self._by_type: dict[type, dict[int, Any]] = {kind: {} for kind in VARIABLE_TYPES}
        self._fixed_references: set[int] = set()
        self._initialized = False
        self.start_time = 0.0
        self.stop_time: float | None = None
        # the buffered inputs, then the step's current time and size (written by the loader's doStep)
        self._inputs = np.zeros(len(self.buffered_inputs) + 2)
        self._outputs = np.zeros(len(self.buffered_outputs))
        self._replay: Any = None  # a fast step's outcome that pythonfmu's doStep returns or raises
        self.fast_path_bound = False

    # ----------------------------------------------------------------- declarations
    def _declare(self, variable, start) -> None:
        low, high = getattr(variable, "minimum", None), getattr(variable, "maximum", None)
        if (low is not None and start < low) or (high is not None and start > high):
            raise ValueError(f"variable {variable.name}: start {start} outside [{low}, {high}]")
        name = variable.local_name
        buffered = self.buffer_of(name)
        if buffered is not None:  # the attribute is the array's element; getter and setter use it directly
            kind, index = buffered
            buffer = "_inputs" if kind == "input" else "_outputs"
            convert = next(
                c for k, c in ((Boolean, bool), (Integer, int), (Real, float)) if isinstance(variable, k)
            )
            if not isinstance(type(self).__dict__.get(name), property):
                setattr(type(self), name, buffered_property(buffer, index, convert))
            getattr(self, buffer)[index] = start
            variable.getter = partial(getattr(self, buffer).item, index)
            variable.setter = partial(getattr(self, buffer).__setitem__, index)
        else:
            setattr(self, name, start)
            # builtins bound to the name (pythonfmu's default lambdas cost a Python frame per value)
            variable.getter = partial(getattr, self, name)
            if variable.variability != Fmi2Variability.constant:
                variable.setter = partial(setattr, self, name)
        self.register_variable(variable)
        self._declared.append(variable)

    def buffer_of(self, name: str) -> tuple[str, int] | None:
        """("input" or "output", index into that array of :meth:`fast_path_buffers`) of a buffered variable,
        None for the others."""
        if name in self.buffered_inputs:
            return "input", self.buffered_inputs.index(name)
        if name in self.buffered_outputs:
            return "output", self.buffered_outputs.index(name)
        return None

    def fast_path_buffers(self) -> tuple[np.ndarray, np.ndarray]:
        """The arrays the loader's Get/Set calls read and write in C (module docstring: the fast path): the
        buffered inputs, then two places for the step's current time and size; the buffered outputs."""
        return self._inputs, self._outputs

    @property
    def declared_variables(self) -> tuple:
        """The variables this instance declared, in declaration order."""
        return tuple(self._declared)

    def register_variable(self, var, nested: bool = True) -> None:
        """pythonfmu's registration, plus the lookup tables of the Get/Set calls (module docstring)."""
        super().register_variable(var, nested)
        kind = next(k for k in VARIABLE_TYPES if isinstance(var, k))
        self._by_type[kind][var.value_reference] = var
        if var.causality == Fmi2Causality.parameter and var.variability in (
            Fmi2Variability.fixed,
            Fmi2Variability.constant,
        ):
            self._fixed_references.add(var.value_reference)

    def declare_real(
        self,
        name: str,
        causality: str,
        *,
        start: float,
        unit: str,
        description: str,
        minimum: float | None = None,
        maximum: float | None = None,
        variability: str | None = None,
    ) -> None:
        """Declare a Real variable, set ``self.<name> = start`` and register it."""
        attributes = variable_attributes(causality, "Real", variability)
        start = float(start)
        variable = UnitReal(
            name,
            unit=unit,
            minimum=minimum,
            maximum=maximum,
            description=description,
            start=start,
            **attributes,
        )
        self._declare(variable, start)

    def declare_integer(
        self,
        name: str,
        causality: str,
        *,
        start: int,
        description: str,
        minimum: int | None = None,
        maximum: int | None = None,
        variability: str | None = None,
    ) -> None:
        """Declare an Integer variable, set ``self.<name> = start`` and register it."""
        attributes = variable_attributes(causality, "Integer", variability)
        variable = RangedInteger(
            name,
            minimum=minimum,
            maximum=maximum,
            description=description,
            start=int(start),
            **attributes,
        )
        self._declare(variable, int(start))

    def declare_boolean(
        self,
        name: str,
        causality: str,
        *,
        start: bool,
        description: str,
        variability: str | None = None,
    ) -> None:
        """Declare a Boolean variable, set ``self.<name> = start`` and register it."""
        attributes = variable_attributes(causality, "Boolean", variability)
        variable = DescribedBoolean(name, description=description, start=bool(start), **attributes)
        self._declare(variable, bool(start))

    def declare_string(
        self,
        name: str,
        causality: str,
        *,
        start: str,
        description: str,
        variability: str | None = None,
    ) -> None:
        """Declare a String variable, set ``self.<name> = start`` and register it."""
        attributes = variable_attributes(causality, "String", variability)
        variable = DescribedString(name, description=description, start=str(start), **attributes)
        self._declare(variable, str(start))

    def to_xml(self, model_options: dict[str, str] | None = None) -> Element:
        """pythonfmu's modelDescription plus ``<UnitDefinitions>`` after ``<CoSimulation>``."""
        root = super().to_xml(model_options or {})
        units = {v.unit for v in self.vars.values() if getattr(v, "unit", None)}
        if units:
            position = list(root).index(root.find("CoSimulation")) + 1
            root.insert(position, unit_definitions_xml(units))
        return root

    # --------------------------------------------------------------- initialization
    def validate_parameters(self) -> None:
        """Check parameters beyond their declared ranges; raise ``InputError`` naming the input."""

    def setup(self) -> None:
        """Build the model from the (validated) parameters; runs at the end of initialization."""

    def _range_problems(self) -> list[str]:
        problems = []
        for variable in self._declared:
            if variable.causality != Fmi2Causality.parameter:
                continue
            value = getattr(self, variable.local_name)
            low, high = getattr(variable, "minimum", None), getattr(variable, "maximum", None)
            if isinstance(variable, UnitReal) and not math.isfinite(value):
                problems.append(f"{variable.name} must be finite, got {value!r}")
                continue
            if low is None and high is None:
                continue
            unit = f" {variable.unit}" if getattr(variable, "unit", None) else ""
            if (low is not None and value < low) or (high is not None and value > high):
                low_text = "-inf" if low is None else f"{low:g}"
                high_text = "inf" if high is None else f"{high:g}"
                problems.append(
                    f"{variable.name} must lie in [{low_text}, {high_text}]{unit}, got {value:g}{unit}"
                )
        return problems

    def fail(self, problems: list[str], call: str) -> None:
        """Log each problem at status error, then raise (pythonfmu turns it into fmi2Fatal; the loader into
        fmi2Error when the call was flagged as refused)."""
        for problem in problems:
            self.log(f"{self.instance_name}: {problem}", Fmi2Status.error)
        raise SlaveInitializationError(f"{call}: " + "; ".join(problems))

    def setup_experiment(self, start_time: float, stop_time=None, tolerance=None):
        """Keep the experiment's start and stop times [s] (pythonfmu calls this on entering
        initialization mode)."""
        self.start_time = float(start_time)
        self.stop_time = None if stop_time is None else float(stop_time)

    def exit_initialization_mode(self):
        problems = self._range_problems()
        refused = bool(problems)  # the user's input: fmi2Error (module docstring); else an internal error
        if not problems:
            try:
                self.validate_parameters()
                self.setup()
            except InputError as error:
                problems, refused = [str(error)], True
            except Exception as error:
                problems = [f"internal error {type(error).__name__}: {error}"]
                self.log(traceback.format_exc(), Fmi2Status.error)
        if problems:
            if refused:
                self._flag_refused_call()
            self.fail(problems, "initialization")
        self._initialized = True
        self._bind_fast_path()

    # -------------------------------------------------------------------- fast path
    def _bind_fast_path(self) -> None:
        """Hand the buffers to the FMU's loader (module docstring); without one, or with
        ``OILWATCH_FMU_FAST_PATH=0``, every call stays on the Python path."""
        if self.buffered_inputs or self.buffered_outputs:
            self.fast_path_bound = bind_buffers(self, self._fast_step)

    def _fast_step(self) -> int:
        """The loader's fmi2DoStep (module docstring), the GIL held: :meth:`do_step` at the time and step
        size the loader wrote after the inputs; :data:`STEP_DONE` when it succeeded and logged nothing, else
        :data:`STEP_REPLAY` with its outcome kept for pythonfmu's doStep."""
        try:
            outcome = self.do_step(self._inputs.item(-2), self._inputs.item(-1))
        except BaseException as error:  # pythonfmu's doStep raises it again
            self._replay = error
            return STEP_REPLAY
        if outcome is True and not self.log_queue:
            return STEP_DONE
        self._replay = outcome
        return STEP_REPLAY

    # ------------------------------------------------------------------ get and set
    def refuse_fixed_after_initialization(self, vrs, values, call: str) -> None:
        """Fail (module docstring) when ``call``, made after initialization, sets a fixed parameter among the
        value references ``vrs``; nothing is set then."""
        if not self._initialized or self._fixed_references.isdisjoint(vrs):
            return
        fixed = self._fixed_references
        problems = [
            f"{self.vars[vr].name} is a fixed parameter: it can be set only before "
            f"{self.initialization_end_call}; {value!r} was not applied (reset the instance to change it)"
            for vr, value in zip(vrs, values, strict=True)
            if vr in fixed
        ]
        self._flag_refused_call()
        self.fail(problems, call)

    def _flag_refused_call(self) -> None:
        """The current call refuses the user's input: fmi2Error / fmi3Error through the FMU's binary (module
        docstring), the instance kept alive through the wrapper's cleanup."""
        if flag_refused_call_to_loader(self.resources):
            outlive_the_wrappers_cleanup(self.fmi_facade)

    def _set(self, kind: type, call: str, vrs, values) -> None:
        self.refuse_fixed_after_initialization(vrs, values, call)
        table = self._by_type[kind]
        try:  # the setters are setattr (no KeyError of their own)
            for vr, value in zip(vrs, values, strict=True):
                table[vr].setter(value)
        except KeyError as error:
            raise TypeError(f"Variable with valueReference={error} is not of type {kind.__name__}!") from None

    def refresh_outputs(self, vrs) -> None:
        """Bring the outputs among the value references ``vrs`` up to date before they are read: a slave that
        computes its outputs only when asked overrides this. Every read goes through it: the Get calls, the
        FMU state and the FMI 3.0 shell (:mod:`oilwatch.fmu_src.fmi3_shell`)."""

    def _get(self, kind: type, convert, vrs) -> list:
        self.refresh_outputs(vrs)
        table = self._by_type[kind]
        try:  # the getters are getattr (no KeyError of their own)
            return [convert(table[vr].getter()) for vr in vrs]
        except KeyError as error:
            raise TypeError(f"Variable with valueReference={error} is not of type {kind.__name__}!") from None

    def set_real(self, vrs, values):
        self._set(Real, "fmi2SetReal", vrs, values)

    def set_integer(self, vrs, values):
        self._set(Integer, "fmi2SetInteger", vrs, values)

    def set_boolean(self, vrs, values):
        self._set(Boolean, "fmi2SetBoolean", vrs, values)

    def set_string(self, vrs, values):
        self._set(String, "fmi2SetString", vrs, values)

    def get_real(self, vrs):
        return self._get(Real, float, vrs)

    def get_integer(self, vrs):
        return self._get(Integer, int, vrs)

    def get_boolean(self, vrs):
        return self._get(Boolean, bool, vrs)

    def get_string(self, vrs):
        return self._get(String, str, vrs)

    def do_step(self, current_time: float, step_size: float) -> bool:
        """Advance by ``step_size`` [s]; exceptions of :meth:`step` are logged, then re-raised. After a fast
        step that needs pythonfmu (:meth:`_fast_step`), return or raise its outcome instead."""
        if self._replay is not None:
            outcome, self._replay = self._replay, None
            if isinstance(outcome, BaseException):
                if isinstance(outcome, InputError):  # refused in the fast step: flag this (replaying) call
                    self._flag_refused_call()
                raise outcome
            return outcome
        if not self._initialized:  # the wrong state: fmi2Error naming it, not an AttributeError's fmi2Fatal
            self._flag_refused_call()
            self.fail(
                [
                    f"fmi2DoStep called before {self.initialization_end_call} (the instance is not "
                    "initialized)"
                ],
                "fmi2DoStep",
            )
        try:
            return self.step(current_time, step_size) is not False
        except Exception as error:
            self.log(
                f"{self.instance_name}: do_step at t = {current_time:.9g} s failed: "
                f"{type(error).__name__}: {error}",
                Fmi2Status.error,
            )
            if isinstance(error, InputError):  # an input refused at this step: fmi2Error (module docstring)
                self._flag_refused_call()
            raise

    def step(self, current_time: float, step_size: float) -> bool | None:
        """The slave's step; return False to report fmi2Discard."""
        raise NotImplementedError

    # ------------------------------------------------------------------------ state
    def _get_fmu_state(self) -> dict[str, Any]:
        self.refresh_outputs(self.vars.keys())
        state = super()._get_fmu_state()
        state["__attributes__"] = {name: copy.deepcopy(getattr(self, name)) for name in self.state_attributes}
        return state

    def _set_fmu_state(self, state: dict[str, Any]):
        state = dict(state)
        attributes = state.pop("__attributes__", {})
        super()._set_fmu_state(state)
        for name, value in attributes.items():
            setattr(self, name, copy.deepcopy(value))

    @staticmethod
    def _fmu_state_to_bytes(state: dict[str, Any]) -> bytes:
        return pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL)

    @staticmethod
    def _fmu_state_from_bytes(state: bytes) -> dict[str, Any]:
        """A state of :meth:`_fmu_state_to_bytes`; other bytes raise an error that says so (pythonfmu logs
        it with its fmi2Fatal: the call is static, it cannot flag a refusal)."""
        try:
            restored = pickle.loads(state)
        except Exception as error:
            raise InputError(
                f"fmi2DeSerializeFMUstate: the {len(state)} bytes are not a serialized state of this FMU "
                f"({type(error).__name__}: {error})"
            ) from None
        if not isinstance(restored, dict):
            raise InputError(
                f"fmi2DeSerializeFMUstate: the {len(state)} bytes are not a serialized state of this FMU "
                f"(they hold a {type(restored).__name__})"
            )
        return restored
