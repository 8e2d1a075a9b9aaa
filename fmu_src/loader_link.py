"""The link between an oilwatch slave and its FMU's own binary, oilwatch's loader
(``oilwatch/cosim/native/fmi2_loader.c``; FMI 3.0: ``native/fmi3_refusal.c``), found through the slave's
resources folder with ctypes: the refusal flag (fmi2Error for the user's input) and the fast path's binding
(:mod:`oilwatch.fmu_src.slave_base`, module docstring)."""

from __future__ import annotations

import ctypes
import os
from pathlib import Path

import numpy as np
from pythonfmu.variables import Boolean, Integer, Real

REFUSED_CALL_ENTRY = "oilwatch_loader_refused_call"
"""The loader's entry point that turns the current call's fmi2Fatal into fmi2Error."""
BIND_ENTRY = "oilwatch_loader_bind_buffers"
"""The FMI 2.0 loader's entry point of the fast path (module docstring)."""
BIND_STEP_ENTRY = "oilwatch_loader_bind_plain_step"
"""The FMI 2.0 loader's entry point of the compiled plain step (:mod:`oilwatch.fmu_src.ekf_plain_step`)."""
FAST_PATH_VARIABLE = "OILWATCH_FMU_FAST_PATH"
"""Environment variable: ``0`` keeps every FMI call on the Python path; ``python`` binds the buffers but not
a compiled step (every doStep calls the slave's Python step)."""
SLOT_REAL_INPUT, SLOT_REAL_OUTPUT, SLOT_INTEGER_OUTPUT, SLOT_BOOLEAN_OUTPUT = 1, 2, 3, 4
SLOT_SHIFT = 24
"""The fast path's table by value reference: ``kind << SLOT_SHIFT | index``, -1 when not bound (as in
``oilwatch/cosim/native/fmi2_loader.c``)."""
STEP_DONE, STEP_REPLAY = 0, 1
""":meth:`OilwatchSlave._fast_step`'s answers: done, or replay the stored outcome through pythonfmu."""


def loader_entry(resources: str | None, name: str, library=ctypes.CDLL):
    """The function ``name`` of the FMU's own binary (the one beside ``resources/`` that is already mapped
    into this process: it is what the host loaded, so ``ctypes`` opens the same copy and nothing new is
    loaded), opened as ``library`` (``ctypes.PyDLL`` keeps the GIL during the call); None without one."""
    if not resources:
        return None
    binaries = Path(resources).parent / "binaries"
    try:
        mapped = Path("/proc/self/maps").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    # FMI 2.0's folder and FMI 3.0's (its layer over pythonfmu3, oilwatch/cosim/native/fmi3_refusal.c)
    for binary in sorted([*binaries.glob("linux64/*.so"), *binaries.glob("x86_64-linux/*.so")]):
        if str(binary.resolve()) in mapped:
            entry = getattr(library(str(binary)), name, None)
            if entry is not None:
                return entry
    return None


def flag_refused_call_to_loader(resources: str | None) -> bool:
    """Tell the FMU's loader (module docstring) that the current FMI call refuses the user's input; return
    whether a loader took the flag (its entry point :data:`REFUSED_CALL_ENTRY`)."""
    entry = loader_entry(resources, REFUSED_CALL_ENTRY)
    if entry is None:
        return False
    entry.restype = None
    entry()
    return True


def python_type(variable) -> type:
    """The Python type of a declared variable's values."""
    types = ((Boolean, bool), (Integer, int), (Real, float))
    return next(t for kind, t in types if isinstance(variable, kind))


def outlive_the_wrappers_cleanup(facade) -> None:
    """Take one more reference to the object pythonfmu's (or pythonfmu3's) C++ wrapper holds, its class and
    its log queue, before an exception the host will see as fmi2Error / fmi3Error.

    On every Python exception the wrapper's ``handle_py_exception`` calls ``cleanPyObject``, which releases
    its references to the instance, the class and the log queue (``Py_XDECREF`` of ``pInstance_``,
    ``pClass_``, ``pMessages_``) but keeps the pointers and uses them in the next call and again when the
    instance is freed. After fmi2Fatal nothing more is called; after a refused input the host steps on, and
    without these references the instance would be used after its release (a crash at the next garbage
    collection or at exit)."""
    for held in (facade, type(facade), facade._get_log_queue()):
        ctypes.pythonapi.Py_IncRef(ctypes.py_object(held))


def fast_path_slots(slave) -> np.ndarray:
    """The loader's table by value reference of ``slave``'s buffered variables (kind << SLOT_SHIFT | index
    into its array, -1 for the others)."""
    slots = np.full(max(slave.vars, default=-1) + 1, -1, dtype=np.intc)
    outputs = ((Boolean, SLOT_BOOLEAN_OUTPUT), (Integer, SLOT_INTEGER_OUTPUT), (Real, SLOT_REAL_OUTPUT))
    for vr, variable in slave.vars.items():
        buffered = slave.buffer_of(variable.local_name)
        if buffered is None:
            continue
        buffer, index = buffered
        output = next(slot for k, slot in outputs if isinstance(variable, k))
        kind = SLOT_REAL_INPUT if buffer == "input" else output
        slots[vr] = (kind << SLOT_SHIFT) | index
    return slots


def bind_buffers(slave, step) -> bool:
    """Hand ``slave``'s fast-path arrays (its buffered inputs, then two places for the step's time and
    size, and its buffered outputs), their table and ``step`` (called by the loader's fmi2DoStep, returns
    :data:`STEP_DONE` or :data:`STEP_REPLAY`) to the FMU's loader; return whether it took them (not with
    ``OILWATCH_FMU_FAST_PATH=0``, nor without an FMI 2.0 loader of this version, nor outside its
    fmi2ExitInitializationMode)."""
    if os.environ.get(FAST_PATH_VARIABLE) == "0":
        return False
    entry = loader_entry(slave.resources, BIND_ENTRY, ctypes.PyDLL)
    if entry is None:
        return False
    slots = fast_path_slots(slave)
    pointer, size = ctypes.c_void_p, ctypes.c_size_t
    entry.argtypes = (pointer, size, pointer, size, pointer, size, ctypes.py_object)
    entry.restype = ctypes.c_int
    inputs, outputs = slave.fast_path_buffers()
    arguments = (inputs.ctypes.data, len(inputs) - 2, outputs.ctypes.data, len(outputs))
    return bool(entry(*arguments, slots.ctypes.data, len(slots), step))


def bind_plain_step(slave, table) -> bool:
    """Hand the loader a compiled step for its fmi2DoStep (e.g. :mod:`oilwatch.fmu_src.ekf_plain_step`:
    ``table``'s ``function``, ``int f(void *)``, and its argument ``address``, which the slave keeps alive),
    after
    :func:`bind_buffers`; return whether it took it (not with ``OILWATCH_FMU_FAST_PATH`` ``0`` or
    ``python``, nor without a loader of this version)."""
    if os.environ.get(FAST_PATH_VARIABLE) in ("0", "python"):
        return False
    entry = loader_entry(slave.resources, BIND_STEP_ENTRY, ctypes.PyDLL)
    if entry is None:
        return False
    entry.argtypes = (ctypes.c_void_p, ctypes.c_void_p)
    entry.restype = ctypes.c_int
    return bool(entry(table.function, table.address))
