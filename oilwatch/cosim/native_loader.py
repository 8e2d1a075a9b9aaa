"""Make a pythonfmu FMU self-sufficient on Linux: oilwatch's C loader as the FMU's binary.

pythonfmu's export binary does not link libpython: it runs only in a host that already holds a Python
interpreter. :func:`install_loader` rewrites a built FMU so that

- ``binaries/linux64/<modelIdentifier>.so`` is the loader compiled from ``native/fmi2_loader.c``
  (with the system C compiler, at build time; the source ships with the package),
- ``binaries/linux64/pythonfmu_export.so`` is pythonfmu's original binary, which the loader opens,
- ``resources/oilwatch_python.txt`` records the Python that built the FMU (:func:`python_record`):
  its libpython, its prefix and the site-packages folders of the build environment.

The loader starts that Python in a host that has none, checks that numpy, scipy and numba import,
and forwards every fmi2 call; see the comment at the top of ``native/fmi2_loader.c`` (also for the
teardown fix). The environment variables ``OILWATCH_PYTHON_LIB``, ``OILWATCH_PYTHONHOME`` and
``OILWATCH_PYTHON_ENV`` override the record.
"""

from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from pathlib import Path

from models.validation import InputError

LOADER_SOURCE = Path(__file__).resolve().parent / "native" / "fmi2_loader.c"
RECORD_NAME = "resources/oilwatch_python.txt"
INNER_BINARY = "pythonfmu_export.so"
PLATFORM = "linux64"
COMPILE_FLAGS = ("-shared", "-fPIC", "-O2", "-fvisibility=hidden", "-Wall", "-Wno-format-truncation")


def python_library() -> Path:
    """The shared libpython of the running interpreter (``sysconfig`` LIBDIR / INSTSONAME)."""
    libdir = sysconfig.get_config_var("LIBDIR") or ""
    for name in (sysconfig.get_config_var("INSTSONAME"), sysconfig.get_config_var("LDLIBRARY")):
        if name and ".so" in name:
            path = Path(libdir) / name
            if path.is_file():
                return path
    version = f"{sys.version_info.major}.{sys.version_info.minor}"
    raise InputError(
        f"this Python ({sys.executable}) has no shared libpython{version}.so in {libdir!r}: build the FMUs "
        "with a Python configured with --enable-shared (Debian: package libpython" + version + ")"
    )


def python_record() -> str:
    """The ``resources/oilwatch_python.txt`` text for the running interpreter and environment."""
    version = f"{sys.version_info.major}.{sys.version_info.minor}"
    folders = []
    paths = sysconfig.get_paths()
    for folder in (*site.getsitepackages(), paths["purelib"], paths["platlib"]):
        if folder not in folders and Path(folder).is_dir():
            folders.append(folder)
    lines = {
        "python_version": version,
        "python_library": str(python_library()),
        "python_home": sys.base_prefix,
        "site_packages": os.pathsep.join(folders),
    }
    return "".join(f"{key}={value}\n" for key, value in lines.items())


def compile_loader(destination: Path, compiler: str | None = None) -> Path:
    """Compile ``native/fmi2_loader.c`` into the shared library ``destination``; return it."""
    compiler = compiler or os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not compiler:
        raise InputError("no C compiler found (cc, gcc or $CC): it is needed to build the FMUs' loader")
    command = [compiler, *COMPILE_FLAGS, "-o", str(destination), str(LOADER_SOURCE), "-ldl", "-lpthread"]
    process = subprocess.run(command, capture_output=True, text=True)
    if process.returncode != 0:
        raise InputError(f"compiling the FMU loader failed ({' '.join(command)}):\n{process.stderr}")
    return destination


def install_loader(fmu: Path, model_identifier: str) -> Path:
    """Put the loader into the built ``fmu`` in place of pythonfmu's binary (see the module docstring)."""
    fmu = Path(fmu)
    binary = f"binaries/{PLATFORM}/{model_identifier}.so"
    with tempfile.TemporaryDirectory(prefix="oilwatch_loader_") as tmp:
        loader = compile_loader(Path(tmp) / "loader.so")
        rewritten = Path(tmp) / fmu.name
        with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(rewritten, "w", zipfile.ZIP_DEFLATED) as target:
            names = source.namelist()
            if binary not in names:
                raise InputError(f"{fmu}: no {binary} to wrap")
            for info in source.infolist():
                if info.filename in (RECORD_NAME, f"binaries/{PLATFORM}/{INNER_BINARY}"):
                    continue
                data = source.read(info)
                if info.filename == binary:
                    target.writestr(f"binaries/{PLATFORM}/{INNER_BINARY}", data)
                    target.write(loader, binary)
                else:
                    target.writestr(info, data)
            target.writestr(RECORD_NAME, python_record())
        shutil.move(rewritten, fmu)
    return fmu
