"""FMI 3.0 co-simulation FMUs in the master: :class:`Slave3`, the fmpy.fmi3 counterpart of :class:`Slave`.

:func:`open_slave` reads an FMU's ``fmiVersion`` and returns a :class:`~oilwatch.cosim.loading.Slave`
(FMI 2.0) or a :class:`Slave3` (FMI 3.0). A Slave3 presents its variables under FMI 2.0 type names
(Float64 -> Real, Int32 -> Integer; Boolean, String), so connections, ports, recorders and SSP files treat
both versions alike; only the FMI calls differ (``fmi3EnterInitializationMode`` carries the experiment,
``fmi3DoStep`` reports events and early return, Booleans are C ``bool``, array-capable getters take the
number of values).

Teardown: pythonfmu3's binary has pythonfmu 0.7's defect (its interpreter guard is released twice at
process exit, PythonFMU issues #228/#229); the FMU's own layer in front of it (``native/fmi3_refusal.c``)
releases the guard once, first, in any host.
"""

from __future__ import annotations

import zipfile
from ctypes import byref, c_bool, c_double, c_int32
from pathlib import Path

from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave, fmi3Boolean, fmi3Float64

from .errors import SlaveError, SystemDescriptionError
from .loading import Slave

FMI3_TYPES = {"Float64": "Real", "Int32": "Integer", "Boolean": "Boolean", "String": "String"}
"""FMI 3.0 variable types the master exchanges, and the FMI 2.0 name each is presented under."""
_FMI3_KIND = {"Real": "Float64", "Integer": "Int32", "Enumeration": "Int64", "Boolean": "Boolean"}
_CTYPES3 = {"Real": c_double, "Integer": c_int32, "Boolean": c_int32}


def fmi_version(path: str | Path) -> str:
    """The ``fmiVersion`` of an FMU file (a missing or corrupt file gives a SystemDescriptionError)."""
    path = Path(path)
    if not path.is_file():
        raise SystemDescriptionError(f"FMU file {path} does not exist")
    if not zipfile.is_zipfile(path):
        raise SystemDescriptionError(f"FMU file {path} is corrupt: not a ZIP archive")
    try:
        return read_model_description(str(path), validate=False).fmiVersion
    except Exception as error:
        raise SystemDescriptionError(
            f"FMU file {path} is corrupt: cannot read its modelDescription.xml ({error})"
        ) from None


def open_slave(name: str, path: str | Path, log_size: int = 50) -> Slave:
    """Instantiate the FMU at ``path`` as instance ``name``: FMI 2.0 or 3.0 co-simulation."""
    version = fmi_version(path)
    if version.startswith("3."):
        return Slave3(name, path, log_size)
    return Slave(name, path, log_size)


class Slave3(Slave):
    """One instantiated FMI 3.0 co-simulation FMU (same interface as :class:`Slave`)."""

    fmi_version = "3.0"
    fmu_class = FMU3Slave
    type_names = FMI3_TYPES

    def _instantiate(self) -> None:
        self.call(
            "fmi3InstantiateCoSimulation", self.fmu.instantiate, loggingOn=True, logMessage=self._receive
        )
        self._do_step = self.fmu._functions["fmi3DoStep"]
        self._step_flags = [fmi3Boolean(), fmi3Boolean(), fmi3Boolean(), fmi3Float64()]
        self._step_refs = [byref(flag) for flag in self._step_flags]

    def _receive(self, _environment, status, _category, message) -> None:
        self.receive_log(status, message)

    def call(self, fname: str, function, *args, **kwargs):
        if fname == "fmi3InstantiateCoSimulation":
            try:
                return function(*args, **kwargs)
            except FMICallException as error:
                raise self.fail(error.function, error.status) from None
            except Exception as error:
                raise SlaveError(self.name, fname, None, f"failure ({error})", list(self.log)[-5:]) from None
        return super().call(fname, function, *args, **kwargs)

    def ctype(self, type_name: str):
        try:
            return _CTYPES3[type_name]
        except KeyError:
            raise SystemDescriptionError(f"{self.name}: cannot exchange {type_name} variables") from None

    def raw_accessor(self, kind: str, direction: str):
        name = f"fmi3{direction}{_FMI3_KIND.get(kind, kind)}"
        function = self.fmu._functions[name]
        if kind != "Boolean":
            return name, lambda component, vrs, n, values: function(component, vrs, n, values, n)
        # Booleans are C bool in FMI 3.0; the port keeps FMI 2.0's int buffer (recorders write 0/1)
        flags = {}

        def exchange(component, vrs, n, values):
            buffer = flags.get(n) or flags.setdefault(n, (c_bool * n)())
            if direction == "Set":
                buffer[:] = [bool(v) for v in values]
            status = function(component, vrs, n, buffer, n)
            if direction == "Get":
                values[:] = [int(v) for v in buffer]
            return status

        return name, exchange

    def set_values(self, values: dict[str, object]) -> None:
        for name, value in values.items():
            variable = self.variable(name)
            value = self.checked_value(name, value)
            vr = [variable.value_reference]
            setter = {
                "Real": (self.fmu.setFloat64, float),
                "Integer": (self.fmu.setInt32, int),
                "Boolean": (self.fmu.setBoolean, bool),
                "String": (self.fmu.setString, str),
            }.get(variable.type)
            if setter is None:
                raise SystemDescriptionError(f"{self.name}.{name}: unsupported type {variable.type}")
            function, convert = setter
            self.call(
                f"fmi3Set{_FMI3_KIND.get(variable.type, variable.type)}", function, vr, [convert(value)]
            )

    def get_values(self, names: list[str]) -> dict[str, object]:
        result = {}
        for name in names:
            variable = self.variable(name)
            getter = {
                "Real": self.fmu.getFloat64,
                "Integer": self.fmu.getInt32,
                "Boolean": self.fmu.getBoolean,
                "String": self.fmu.getString,
            }[variable.type]
            value = self.call(f"fmi3Get{variable.type}", getter, [variable.value_reference])[0]
            result[name] = value.decode() if isinstance(value, bytes) else value
        return result

    def initialize(
        self, start_time: float, stop_time: float | None, values: dict, labels: dict[str, str] | None = None
    ) -> None:
        """fmi3EnterInitializationMode (with the experiment), set ``values``, fmi3ExitInitializationMode."""
        if labels is not None:
            self.labels = dict(labels)
        self.time = start_time
        self.call(
            "fmi3EnterInitializationMode",
            self.fmu.enterInitializationMode,
            startTime=start_time,
            stopTime=stop_time,
        )
        self.set_values(values)
        self.call("fmi3ExitInitializationMode", self.fmu.exitInitializationMode)

    def do_step(self, time: float, step_size: float) -> None:
        """fmi3DoStep from ``time`` [s] by ``step_size`` [s] (discard, or a requested stop, is a failure)."""
        self.time = time
        status = self._do_step(self.component, time, step_size, True, *self._step_refs)
        if status > 1:
            raise self.fail("fmi3DoStep", status)
        if self._step_flags[1].value:
            raise SlaveError(
                self.name, "fmi3DoStep", time, "terminateSimulation requested", list(self.log)[-5:]
            )
        self.time = time + step_size

    def reset(self) -> None:
        self.call("fmi3Reset", self.fmu.reset)
        self.time = None

    def terminate(self) -> None:
        self.call("fmi3Terminate", self.fmu.terminate)

    def close(self) -> None:
        """Free the instance and the library, remove files."""
        if self.instantiated and not self.dead:
            self.fmu.fmi3FreeInstance(self.component)
            self.fmu.freeLibrary()
        self.instantiated = False
        self._remove_extraction()
