"""Make a pythonfmu FMU self-sufficient on Linux: oilwatch's C loader as the FMU's binary.

pythonfmu's export binary does not link libpython: it runs only in a host that already holds a Python
interpreter. :func:`install_loader` rewrites a built FMU so that

- ``binaries/linux64/<modelIdentifier>.so`` is the loader compiled from ``native/fmi2_loader.c``
  (with the system C compiler, at build time; the source ships with the package),
- ``binaries/linux64/pythonfmu_export.so`` is pythonfmu's original binary, which the loader opens,
- ``resources/oilwatch_python.txt`` names the environment that built the FMU (:func:`python_record`): the
  default for a host without Python on the build machine.

In a host that has no Python the loader starts the Python of one environment folder, ``OILWATCH_PYTHON_ENV``
or else the recorded one (a virtual environment: its ``pyvenv.cfg`` gives the base Python and its version,
any 3.10 or newer; or a Python installation prefix), checks that numpy, scipy and numba import
and that an oilwatch the process already imported is the bundled one, and forwards every fmi2 call; see the
comment at the top of ``native/fmi2_loader.c`` (also for the teardown fix).

FMI 3.0 (:func:`install_fmi3_refusal`): ``binaries/x86_64-linux/<modelIdentifier>.so`` becomes the thin layer
of ``native/fmi3_refusal.c``, which returns fmi3Error, not pythonfmu3's fmi3Fatal, when the slave refuses the
user's input; pythonfmu3's binary sits beside it as ``<modelIdentifier>_pythonfmu3.so``, a dependency of the
layer under that name (pythonfmu3's binaries all have the soname ``libpythonfmu-export.so``: depending on it
by soname would bind every oilwatch FMI 3.0 FMU in a process to the first one's copy).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from pathlib import Path

from oilwatch.models.validation import InputError

LOADER_SOURCE = Path(__file__).resolve().parent / "native" / "fmi2_loader.c"
FMI3_SOURCE = Path(__file__).resolve().parent / "native" / "fmi3_refusal.c"
FMI3_PLATFORM = "x86_64-linux"
RECORD_NAME = "resources/oilwatch_python.txt"
INNER_BINARY = "pythonfmu_export.so"
PLATFORM = "linux64"
COMPILE_FLAGS = ("-shared", "-fPIC", "-O2", "-fvisibility=hidden", "-Wall", "-Wno-format-truncation")


def python_environment() -> Path:
    """The running environment's folder: the virtual environment (``sys.prefix`` with a ``pyvenv.cfg``) or
    the Python installation; InputError when its Python has no shared libpython (the loader needs one)."""
    libdir = sysconfig.get_config_var("LIBDIR") or ""
    names = (sysconfig.get_config_var("INSTSONAME"), sysconfig.get_config_var("LDLIBRARY"))
    if not any(name and ".so" in name and (Path(libdir) / name).is_file() for name in names):
        version = f"{sys.version_info.major}.{sys.version_info.minor}"
        raise InputError(
            f"this Python ({sys.executable}) has no shared libpython{version}.so in {libdir!r}: build the "
            "FMUs with a Python configured with --enable-shared (Debian: package libpython" + version + ")"
        )
    return Path(sys.prefix)


def python_record() -> str:
    """The ``resources/oilwatch_python.txt`` text: the building environment's folder and Python version."""
    version = f"{sys.version_info.major}.{sys.version_info.minor}"
    return f"python_env={python_environment()}\npython_version={version}\n"


def _compile(command: list[str], what: str) -> None:
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not compiler:
        raise InputError(f"no C compiler found (cc, gcc or $CC): it is needed to build {what}")
    process = subprocess.run([compiler, *command], capture_output=True, text=True)
    if process.returncode != 0:
        raise InputError(f"compiling {what} failed ({' '.join([compiler, *command])}):\n{process.stderr}")


def compile_loader(destination: Path) -> Path:
    """Compile ``native/fmi2_loader.c`` into the shared library ``destination``; return it."""
    _compile(
        [*COMPILE_FLAGS, "-o", str(destination), str(LOADER_SOURCE), "-ldl", "-lpthread"], "the FMU loader"
    )
    return destination


def _replace_binary(fmu: Path, binary: str, inner: str, replacement: Path, extra: dict[str, str]) -> None:
    """Rewrite ``fmu`` with ``replacement`` as ``binary``, the original binary as ``inner`` and the files
    ``extra`` (archive name: text)."""
    rewritten = replacement.parent / f"rewritten_{fmu.name}"
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(rewritten, "w", zipfile.ZIP_DEFLATED) as target:
        if binary not in source.namelist():
            raise InputError(f"{fmu}: no {binary} to wrap")
        for info in source.infolist():
            if info.filename in (*extra, inner):
                continue
            data = source.read(info)
            if info.filename == binary:
                target.writestr(inner, data)
                target.write(replacement, binary)
            else:
                target.writestr(info, data)
        for name, text in extra.items():
            target.writestr(name, text)
    shutil.move(rewritten, fmu)


def install_loader(fmu: Path, model_identifier: str) -> Path:
    """Put the loader into the built ``fmu`` in place of pythonfmu's binary (see the module docstring)."""
    fmu = Path(fmu)
    with tempfile.TemporaryDirectory(prefix="oilwatch_loader_") as tmp:
        loader = compile_loader(Path(tmp) / "loader.so")
        binary = f"binaries/{PLATFORM}/{model_identifier}.so"
        _replace_binary(
            fmu, binary, f"binaries/{PLATFORM}/{INNER_BINARY}", loader, {RECORD_NAME: python_record()}
        )
    return fmu


def install_fmi3_refusal(fmu: Path, model_identifier: str) -> Path:
    """Put ``native/fmi3_refusal.c``'s layer into the built FMI 3.0 ``fmu`` in front of pythonfmu3's binary
    (see the module docstring)."""
    fmu = Path(fmu)
    inner = f"{model_identifier}_pythonfmu3.so"
    with tempfile.TemporaryDirectory(prefix="oilwatch_fmi3_layer_") as tmp:
        stub, layer = Path(tmp) / inner, Path(tmp) / "layer.so"
        empty = Path(tmp) / "empty.c"
        empty.write_text("", encoding="utf-8")
        # a stub with the inner binary's new name as its soname: the layer's DT_NEEDED entry
        _compile(
            ["-shared", "-fPIC", f"-Wl,-soname,{inner}", "-o", str(stub), str(empty)], "the FMI 3.0 layer"
        )
        _compile(
            [
                *COMPILE_FLAGS,
                f'-DINNER_NAME="{inner}"',
                "-o",
                str(layer),
                str(FMI3_SOURCE),
                "-Wl,--no-as-needed",
                f"-L{tmp}",
                f"-l:{inner}",
                "-Wl,-rpath,$ORIGIN",
                "-ldl",
                "-lpthread",
            ],
            "the FMI 3.0 layer",
        )
        binary = f"binaries/{FMI3_PLATFORM}/{model_identifier}.so"
        _replace_binary(fmu, binary, f"binaries/{FMI3_PLATFORM}/{inner}", layer, {})
    return fmu
