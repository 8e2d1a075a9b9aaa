"""Limit the OpenBLAS thread pools of the process an FMU runs in, without threadpoolctl.

An FMU runs inside its host's Python. numpy and scipy each bring their own OpenBLAS, which by default
starts one thread per core; the filter's and the plant's step loops alternate small numpy and scipy.linalg
calls, and with several threads each of them pays a thread wake-up: measured 20-100 times slower
(REFERENCE.md). A host that sets OPENBLAS_NUM_THREADS=1 gets the fast path; one that sets nothing must get it
too, so each oilwatch FMU sets the thread count itself when it is instantiated.

How: threadpoolctl's method, reduced to what the FMUs need and using only the standard library (code
bundled in an FMU imports only numpy, scipy and numba). The OpenBLAS libraries loaded in the process are
found in ``/proc/self/maps`` (the FMUs are linux64 binaries), opened again with ``ctypes`` (the same handle,
no second copy) and given the count through their own ``*openblas_set_num_threads*`` entry point, whatever
its prefix or suffix (``openblas_``, ``scipy_openblas_``, ``..64_``). The setting is process-wide, as any
BLAS thread setting is: the host's own BLAS calls then run on one thread too.
"""

from __future__ import annotations

import ctypes
from pathlib import Path

SET_FUNCTIONS = (
    "openblas_set_num_threads",
    "openblas_set_num_threads64_",
    "scipy_openblas_set_num_threads",
    "scipy_openblas_set_num_threads64_",
)
GET_FUNCTIONS = tuple(name.replace("_set_", "_get_") for name in SET_FUNCTIONS)
"""The matching getters (``openblas_get_num_threads`` and so on)."""


def loaded_openblas_libraries() -> list[str]:
    """Paths of the OpenBLAS shared libraries mapped into this process (empty where /proc is missing)."""
    try:
        maps = Path("/proc/self/maps").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return []
    paths = {line.split(maxsplit=5)[-1] for line in maps.splitlines() if line.count(" ") >= 5}
    return sorted(p for p in paths if p.startswith("/") and "openblas" in Path(p).name.lower())


def _entry(library: ctypes.CDLL, names: tuple[str, ...]):
    for name in names:
        function = getattr(library, name, None)
        if function is not None:
            return function
    return None


def limit_blas_threads(threads: int = 1) -> dict[str, int]:
    """Set every loaded OpenBLAS to ``threads`` threads; return {library path: threads now} for each one.

    numpy and scipy.linalg are imported first so that both libraries are loaded.
    """
    import numpy  # noqa: F401
    import scipy.linalg  # noqa: F401

    result = {}
    for path in loaded_openblas_libraries():
        try:
            library = ctypes.CDLL(path)
        except OSError:
            continue
        setter, getter = _entry(library, SET_FUNCTIONS), _entry(library, GET_FUNCTIONS)
        if setter is None:
            continue
        setter(ctypes.c_int(threads))
        result[path] = int(getter()) if getter is not None else threads
    return result
