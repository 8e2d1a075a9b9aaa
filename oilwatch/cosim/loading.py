"""Load an FMI 2.0 co-simulation FMU with fmpy and wrap its calls so failures name the slave.

:class:`Slave` owns one FMU instance: its extracted folder, its model description (variables by
name), a log of the messages the FMU sent through the FMI logger, and prepared ctypes buffers
(:class:`Port`) for the few get/set calls a master makes every step.
"""

from __future__ import annotations

import itertools
import logging
import re
import weakref
import zipfile
from collections import deque
from ctypes import byref, c_double, c_int, c_uint
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    calloc,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    free,
)
from fmpy.logging import addLoggerProxy

from .errors import SlaveError, SystemDescriptionError
from .extraction import Extraction, extract_fmu
from .values import fmi_value

LOGGER = logging.getLogger("oilwatch.cosim")
STATUS_NAMES = ("ok", "warning", "discard", "error", "fatal", "pending")
_CTYPES = {"Real": c_double, "Integer": c_int, "Boolean": c_int, "Enumeration": c_int}
_LOG_KEYS = itertools.count(1)
_LOG_SINKS: weakref.WeakValueDictionary = weakref.WeakValueDictionary()
_ORPHANED_CALLBACKS: list = []
"""Callback structs of instances that died with fmi2Fatal: never freed, the FMU may still hold them."""


def _dispatch_log(environment, _instance, status, _category, message) -> None:
    slave = _LOG_SINKS.get(environment)
    if slave is not None:
        slave.receive_log(status, message)
    else:
        LOGGER.warning("unattributed FMU log message: %s", message)


_LOGGER_CALLBACK = fmi2CallbackLoggerTYPE(_dispatch_log)


@dataclass(frozen=True)
class Variable:
    """One scalar variable of an FMU (FMI 2.0 names)."""

    name: str
    value_reference: int
    type: str
    causality: str
    variability: str
    unit: str | None
    start: object
    minimum: str | None = None
    maximum: str | None = None


def _read_description(path: Path, version: str = "2.0"):
    if not path.is_file():
        raise SystemDescriptionError(f"FMU file {path} does not exist")
    if not zipfile.is_zipfile(path):
        raise SystemDescriptionError(f"FMU file {path} is corrupt: not a ZIP archive")
    try:
        md = read_model_description(str(path), validate=False)
    except Exception as error:
        raise SystemDescriptionError(
            f"FMU file {path} is corrupt: cannot read its modelDescription.xml ({error})"
        ) from None
    if md.fmiVersion != version or md.coSimulation is None:
        raise SystemDescriptionError(
            f"FMU file {path} is not an FMI {version} co-simulation FMU "
            f"(fmiVersion {md.fmiVersion}, co-simulation {md.coSimulation is not None})"
        )
    return md


class Slave:
    """One instantiated co-simulation FMU.

    ``name`` is the instance name used in connections and error messages; ``path`` the .fmu file.
    Every FMI call goes through :meth:`call` (or a :class:`Port`), which turns a non-OK status into
    a :class:`SlaveError` naming the instance, the FMI function and the simulation time.
    """

    fmi_version = "2.0"
    fmu_class = FMU2Slave
    type_names: ClassVar[dict[str, str]] = {}
    """Variable types presented under another name (FMI 3.0 -> FMI 2.0 names, see fmi3_loading)."""

    def __init__(self, name: str, path: str | Path, log_size: int = 50):
        if not name or not name.replace("_", "").isalnum():
            raise SystemDescriptionError(f"FMU instance name must be letters, digits and '_', got {name!r}")
        self.name = name
        self.path = Path(path)
        self.model_description = _read_description(self.path, self.fmi_version)
        md = self.model_description
        self.variables = {
            v.name: Variable(
                v.name,
                v.valueReference,
                self.type_names.get(v.type, v.type),
                v.causality,
                v.variability,
                v.unit,
                v.start,
                v.min,
                v.max,
            )
            for v in md.modelVariables
            if v.causality != "independent"
        }
        self.log: deque[str] = deque(maxlen=log_size)
        self.time: float | None = None
        self.dead = False
        self.instantiated = False
        self.labels: dict[str, str] = {}
        self._extraction: Extraction | None = None
        try:
            # A persistent folder per FMU content keeps numba's on-disk cache valid across runs.
            self._extraction = extract_fmu(self.path, name)
            self.fmu = self.fmu_class(
                guid=md.guid,
                unzipDirectory=str(self._extraction.folder),
                modelIdentifier=md.coSimulation.modelIdentifier,
                instanceName=name,
            )
        except Exception as error:
            self._remove_extraction()
            raise SystemDescriptionError(
                f"FMU file {self.path} is corrupt or has no binary for this platform ({error})"
            ) from None
        self._instantiate()
        self.instantiated = True
        self.component = self.fmu.component

    def _instantiate(self) -> None:
        self._callbacks = self._make_callbacks()
        # pythonfmu drops every message, errors included, unless loggingOn is true.
        self.call("fmi2Instantiate", self.fmu.instantiate, callbacks=self._callbacks, loggingOn=True)
        self._do_step = self.fmu._functions["fmi2DoStep"]

    def _make_callbacks(self) -> fmi2CallbackFunctions:
        # fmpy's native logger proxy (which formats the variadic message) keeps ONE Python
        # function for the whole process, so every slave shares _dispatch_log and is told apart
        # by the componentEnvironment pointer it was instantiated with.
        key = next(_LOG_KEYS)
        _LOG_SINKS[key] = self
        self._log_key = key
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = _LOGGER_CALLBACK
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        callbacks.componentEnvironment = key
        addLoggerProxy(byref(callbacks))
        return callbacks

    def receive_log(self, status: int, message: bytes | None) -> None:
        """Keep a message the FMU sent through the FMI logger (warnings also go to logging)."""
        text = message.decode("utf-8", "replace") if message else ""
        label = STATUS_NAMES[status] if 0 <= status < len(STATUS_NAMES) else str(status)
        self.log.append(f"[{label.upper()}] {text}")
        if status == 1:
            LOGGER.warning("%s: %s", self.name, text)
        else:
            LOGGER.debug("%s: [%s] %s", self.name, label, text)

    # ----------------------------------------------------------------- FMI calls
    def fail(self, call: str, status: int) -> SlaveError:
        """Record a failed call and return the error to raise."""
        status_name = STATUS_NAMES[status] if 0 <= status < len(STATUS_NAMES) else str(status)
        if status >= 4:
            # FMI 2.0: after fmi2Fatal no function of the FMU may be called again.
            self.dead = True
        return SlaveError(self.name, call, self.time, status_name, self._labelled(list(self.log)[-5:]))

    def _labelled(self, lines: list[str]) -> list[str]:
        """Log lines with each labelled variable as the user gave it (``--q1-pct (q1_initial_ml_min)``)."""
        for name, label in self.labels.items():
            if label != name:
                pattern = re.compile(rf"(?<![\w.]){re.escape(name)}(?!\w)")
                lines = [pattern.sub(f"{label} ({name})", line) for line in lines]
        return lines

    def call(self, fname: str, function, *args, **kwargs):
        """Call ``function`` (an fmpy method); an FMI status above warning raises SlaveError."""
        if self.dead:
            raise SlaveError(self.name, fname, self.time, "not called (instance is dead)", [])
        try:
            result = function(*args, **kwargs)
        except FMICallException as error:
            raise self.fail(error.function, error.status) from None
        except Exception as error:
            if fname == "fmi2Instantiate":
                raise SlaveError(self.name, fname, None, f"failure ({error})", list(self.log)[-5:]) from None
            raise
        return result

    def ctype(self, type_name: str):
        """The ctypes type of one value of ``type_name`` (FMI 2.0 type names)."""
        return _CTYPES[type_name]

    def raw_accessor(self, kind: str, direction: str):
        """``(FMI function name, f(component, vrs, n, values) -> status)`` for a :class:`Port`."""
        name = f"fmi2{direction}{kind}"
        return name, self.fmu._functions[name]

    def variable(self, name: str) -> Variable:
        """The variable called ``name``, or a SystemDescriptionError listing what exists."""
        try:
            return self.variables[name]
        except KeyError:
            raise SystemDescriptionError(
                f"FMU instance '{self.name}' ({self.path.name}) has no variable {name!r}; "
                f"it has {sorted(self.variables)}"
            ) from None

    def checked_value(self, name: str, value: object, label: str | None = None) -> object:
        """``value`` converted to variable ``name``'s FMI type; SystemDescriptionError naming the input as
        the user gave it (``label``, else a label of :attr:`labels`, else ``instance.name``) when it is not
        of that type (:func:`~oilwatch.cosim.values.fmi_value`)."""
        label = label or self.labels.get(name, f"{self.name}.{name}")
        return fmi_value(self.variable(name), value, label)

    def set_values(self, values: dict[str, object]) -> None:
        """Set variables by name (start values of parameters, inputs), each with its own type."""
        for name, value in values.items():
            variable = self.variable(name)
            value = self.checked_value(name, value)
            vr = [variable.value_reference]
            if variable.type == "Real":
                self.call("fmi2SetReal", self.fmu.setReal, vr, [float(value)])
            elif variable.type in ("Integer", "Enumeration"):
                self.call("fmi2SetInteger", self.fmu.setInteger, vr, [int(value)])
            elif variable.type == "Boolean":
                self.call("fmi2SetBoolean", self.fmu.setBoolean, vr, [bool(value)])
            elif variable.type == "String":
                self.call("fmi2SetString", self.fmu.setString, vr, [str(value)])
            else:
                raise SystemDescriptionError(f"{self.name}.{name}: unsupported type {variable.type}")

    def get_values(self, names: list[str]) -> dict[str, object]:
        """Read variables by name (any type), for inspection outside the step loop."""
        result = {}
        for name in names:
            variable = self.variable(name)
            vr = [variable.value_reference]
            getter = {
                "Real": self.fmu.getReal,
                "Integer": self.fmu.getInteger,
                "Enumeration": self.fmu.getInteger,
                "Boolean": self.fmu.getBoolean,
                "String": self.fmu.getString,
            }[variable.type]
            value = self.call(f"fmi2Get{variable.type}", getter, vr)[0]
            result[name] = value.decode() if isinstance(value, bytes) else value
        return result

    def initialize(
        self, start_time: float, stop_time: float | None, values: dict, labels: dict[str, str] | None = None
    ) -> None:
        """setupExperiment, enterInitializationMode, set ``values``, exitInitializationMode.

        labels: how the user gave some of the variables (``{"seed": "--seed"}``), for error messages.
        """
        if labels is not None:
            self.labels = dict(labels)
        self.time = start_time
        self.call("fmi2SetupExperiment", self.fmu.setupExperiment, startTime=start_time, stopTime=stop_time)
        self.call("fmi2EnterInitializationMode", self.fmu.enterInitializationMode)
        self.set_values(values)
        self.call("fmi2ExitInitializationMode", self.fmu.exitInitializationMode)

    def do_step(self, time: float, step_size: float) -> None:
        """fmi2DoStep from ``time`` [s] by ``step_size`` [s] (discard counts as failure)."""
        self.time = time
        status = self._do_step(self.component, time, step_size, 1)
        if status > 1:
            raise self.fail("fmi2DoStep", status)
        self.time = time + step_size

    def reset(self) -> None:
        """fmi2Reset: back to the state after instantiation (the loaded library is kept)."""
        self.call("fmi2Reset", self.fmu.reset)
        self.time = None

    def terminate(self) -> None:
        self.call("fmi2Terminate", self.fmu.terminate)

    def close(self) -> None:
        """Free the instance (unless it died with fmi2Fatal) and release the extracted files (a temporary
        folder is removed; the shared persistent folder of :mod:`~oilwatch.cosim.extraction` is unlocked)."""
        if self.instantiated and not self.dead:
            self.fmu.freeInstance()
        elif self.instantiated:
            # fmi2FreeInstance may not be called after fmi2Fatal, so the FMU keeps pointers into the
            # callback struct (and may log through it until the process ends): it must outlive the Slave.
            _ORPHANED_CALLBACKS.append(self._callbacks)
        self.instantiated = False
        self._remove_extraction()

    @property
    def unzip_directory(self) -> Path | None:
        """The folder the FMU is unpacked into (None once closed)."""
        return None if self._extraction is None else self._extraction.folder

    def _remove_extraction(self) -> None:
        if self._extraction is not None:
            self._extraction.release()
            self._extraction = None


class Port:
    """A prepared get or set of several variables of one type on one slave (for the step loop)."""

    def __init__(self, slave: Slave, names: list[str], type_name: str):
        if type_name not in _CTYPES:
            raise SystemDescriptionError(f"{slave.name}: cannot exchange {type_name} variables")
        self.slave = slave
        self.names = list(names)
        self.type_name = type_name
        vrs = [slave.variable(n).value_reference for n in names]
        self.size = len(vrs)
        self.vrs = (c_uint * self.size)(*vrs)
        self.values = (slave.ctype(type_name) * self.size)()
        kind = "Integer" if type_name == "Enumeration" else type_name
        self._get_name, self._get = slave.raw_accessor(kind, "Get")
        self._set_name, self._set = slave.raw_accessor(kind, "Set")
        self.component = slave.component

    def read(self) -> None:
        """Fill :attr:`values` from the slave."""
        status = self._get(self.component, self.vrs, self.size, self.values)
        if status > 1:
            raise self.slave.fail(self._get_name, status)

    def write(self, values=None) -> None:
        """Write ``values`` (default :attr:`values`) to the slave."""
        buffer = self.values if values is None else values
        status = self._set(self.component, self.vrs, self.size, buffer)
        if status > 1:
            raise self.slave.fail(self._set_name, status)
