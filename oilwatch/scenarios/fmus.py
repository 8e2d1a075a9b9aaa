"""Find the two FMUs (and the SSP) a scenario run needs, built from the installed package when missing.

Default location: ``<cache>/build/<hash>/`` (``<cache>`` is ``$OILWATCH_CACHE`` or ``~/.cache/oilwatch``),
where the hash covers every file that goes into the FMUs: the ``models``, ``estimator`` and ``fmu_src``
packages and the build code, wherever they are installed, and the machine file with its tables (the FMUs
bundle them). Editing the sources or the machine therefore rebuilds on the next run, and a build never goes
stale; the :data:`KEEP_BUILDS` most recently used builds are kept. ``--fmu-dir DIR`` uses FMUs built by hand
(``oilwatch build-fmus --out DIR``) instead and never builds. No source tree is needed: the build is
``oilwatch build-fmus`` (:mod:`oilwatch.cosim.fmu_build`) run in a separate process.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
import tempfile
from pathlib import Path

from oilwatch.models.validation import InputError

from ..cosim.extraction import cache_root, prune
from ..cosim.fmu_build import build_in_subprocess

PLANT_FMU = "RotorBearingPlant.fmu"
EKF_FMU = "OilFlowEKF.fmu"
SYSTEM_SSP = "OilStarvation.ssp"
_BUILD_MODULES = ("packaging.py", "fmu_build.py", "fmu_docs.py", "native_loader.py", "native/fmi2_loader.c")
_SUFFIXES = (".py", ".toml", ".json")
KEEP_BUILDS = 4
"""Builds kept in ``<cache>/build`` (least recently used ones beyond this are deleted)."""


def build_inputs(machine=None) -> list[tuple[str, Path]]:
    """Every file that goes into the FMUs of ``machine`` (default: the bundled turbine), with its name."""
    from oilwatch.models.machine import load_machine

    from ..cosim.fmu_build import FMU_PACKAGES, machine_files, package_dir

    machine = machine if machine is not None else load_machine()
    cosim = Path(__file__).resolve().parents[1] / "cosim"
    files = [(f"oilwatch/cosim/{name}", cosim / name) for name in _BUILD_MODULES]
    for package in FMU_PACKAGES:
        folder = package_dir(package)
        files += [
            (f"{package}/{p.relative_to(folder)}", p)
            for p in sorted(folder.rglob("*"))
            if p.suffix in _SUFFIXES and "__pycache__" not in p.parts
        ]
    files += [(f"machine/{p.name}", p) for p in machine_files(machine)]
    return files


def source_hash(machine=None) -> str:
    """SHA-256 (first 16 hex digits) of the FMUs' input files (:func:`build_inputs`): names and contents."""
    digest = hashlib.sha256(sys.prefix.encode())  # the FMUs record the environment that built them
    for name, path in build_inputs(machine):
        digest.update(name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def default_build_dir(machine=None) -> Path:
    """Where ``ensure_fmus`` builds the FMUs of ``machine`` (default: the bundled turbine)."""
    return cache_root() / "build" / source_hash(machine)


def ensure_fmus(fmu_dir: str | Path | None = None, log=None, machine=None) -> Path:
    """The folder holding RotorBearingPlant.fmu, OilFlowEKF.fmu and OilStarvation.ssp.

    fmu_dir: a folder of prebuilt FMUs (an InputError names a missing file); None: the default build
    folder of ``machine`` (default: the bundled turbine), built first (a few seconds; ``log(text)`` is told)
    when it is missing.
    """
    if fmu_dir is not None:
        folder = Path(fmu_dir)
        for name in (PLANT_FMU, EKF_FMU):
            if not (folder / name).is_file():
                raise InputError(
                    f"--fmu-dir: {folder / name} does not exist (build it with "
                    f"'oilwatch build-fmus --out {folder}', or leave --fmu-dir out to build automatically)"
                )
        return folder
    folder = default_build_dir(machine)
    if all((folder / name).is_file() for name in (PLANT_FMU, EKF_FMU, SYSTEM_SSP)):
        os.utime(folder)
        return folder
    if log is not None:
        log(f"building the FMUs into {folder} ...")
    folder.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".partial-", dir=folder.parent))
    try:
        try:
            build_in_subprocess(staging, None if machine is None else machine.source_path)
        except InputError as error:
            raise InputError(f"building the FMUs failed: {error}") from None
        complete = all((folder / name).is_file() for name in (PLANT_FMU, EKF_FMU, SYSTEM_SSP))
        if not complete:  # another process did not finish first: ours replaces an incomplete earlier build
            if folder.exists():
                aside = Path(tempfile.mkdtemp(prefix=".stale-", dir=folder.parent))
                os.replace(folder, aside / folder.name)
                shutil.rmtree(aside, ignore_errors=True)
            try:
                staging.rename(folder)
            except OSError:
                if not (folder / EKF_FMU).is_file():  # not another process that finished meanwhile
                    raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    prune(folder.parent, KEEP_BUILDS)
    return folder


def plant_and_estimator(fmu_dir: str | Path, name: str = "OilStarvation"):
    """The two-FMU system of ``fmu_dir``: instances ``plant`` and ``ekf``, connected by name."""
    from ..cosim import FmuSpec, SystemDescription

    folder = Path(fmu_dir)
    return SystemDescription(
        [FmuSpec("plant", folder / PLANT_FMU), FmuSpec("ekf", folder / EKF_FMU)], connections=None, name=name
    )
