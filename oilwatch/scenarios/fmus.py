"""Find the two FMUs (and the SSP) a scenario run needs, building them with ``build.py`` when missing.

Default location: ``<cache>/build/<source hash>/`` (``<cache>`` is ``$OILWATCH_CACHE`` or
``~/.cache/oilwatch``), where the hash covers every file that goes into the FMUs (``build.py``, the
``models``, ``estimator`` and ``fmu_src`` packages and the packaging code). Editing the sources therefore
rebuilds on the next run, and a build never goes stale; the :data:`KEEP_BUILDS` most recently used builds
are kept. ``--fmu-dir DIR`` uses FMUs built by hand (``python build.py --out DIR``) instead and never
builds.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from models.validation import InputError

from ..cosim.extraction import cache_root, prune

PLANT_FMU = "RotorBearingPlant.fmu"
EKF_FMU = "OilFlowEKF.fmu"
SYSTEM_SSP = "OilStarvation.ssp"
PACKAGE_ROOT = Path(__file__).resolve().parents[2]
_SOURCES = ("models", "estimator", "fmu_src")
_SOURCE_FILES = (
    "build.py",
    "oilwatch/cosim/packaging.py",
    "oilwatch/cosim/fmu_docs.py",
    "oilwatch/cosim/native_loader.py",
    "oilwatch/cosim/native/fmi2_loader.c",
)
_SUFFIXES = (".py", ".toml", ".json")
KEEP_BUILDS = 4
"""Builds kept in ``<cache>/build`` (least recently used ones beyond this are deleted)."""


def source_root() -> Path:
    """The source tree holding ``build.py``: the one oilwatch runs from (an editable install), else the
    current folder (a clone after ``pip install .``, as the README's set-up does)."""
    for candidate in (PACKAGE_ROOT, Path.cwd()):
        if (candidate / "build.py").is_file() and (candidate / "fmu_src").is_dir():
            return candidate
    raise InputError(
        "cannot build the FMUs: no build.py next to the oilwatch package or in the current folder (run "
        "from the oilwatch source tree), or pass --fmu-dir with FMUs built by 'python build.py --out DIR'"
    )


def source_hash(root: Path) -> str:
    """SHA-256 (first 16 hex digits) of the FMUs' source files: names and contents."""
    files = [root / name for name in _SOURCE_FILES]
    for package in _SOURCES:
        files += sorted(
            p for p in (root / package).rglob("*") if p.suffix in _SUFFIXES and "__pycache__" not in p.parts
        )
    digest = hashlib.sha256(sys.prefix.encode())  # the FMUs record the environment that built them
    for path in files:
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def default_build_dir(root: Path | None = None) -> Path:
    """Where ``ensure_fmus`` builds the sources of ``root`` (default :func:`source_root`)."""
    return cache_root() / "build" / source_hash(root or source_root())


def ensure_fmus(fmu_dir: str | Path | None = None, log=None) -> Path:
    """The folder holding RotorBearingPlant.fmu, OilFlowEKF.fmu and OilStarvation.ssp.

    fmu_dir: a folder of prebuilt FMUs (an InputError names a missing file); None: the default build
    folder, built first (about 2 s; ``log(text)`` is told) when it is missing.
    """
    if fmu_dir is not None:
        folder = Path(fmu_dir)
        for name in (PLANT_FMU, EKF_FMU):
            if not (folder / name).is_file():
                raise InputError(
                    f"--fmu-dir: {folder / name} does not exist (build it with "
                    f"'python build.py --out {folder}', or leave --fmu-dir out to build automatically)"
                )
        return folder
    root = source_root()
    folder = default_build_dir(root)
    if all((folder / name).is_file() for name in (PLANT_FMU, EKF_FMU, SYSTEM_SSP)):
        os.utime(folder)
        return folder
    if log is not None:
        log(f"building the FMUs into {folder} ...")
    folder.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".partial-", dir=folder.parent))
    try:
        # A separate process: building imports the relocated slave modules, which must not linger here.
        process = subprocess.run(
            [sys.executable, str(root / "build.py"), "--out", str(staging)],
            cwd=root,
            capture_output=True,
            text=True,
        )
        if process.returncode != 0:
            lines = (process.stderr or process.stdout).strip().splitlines() or ["(no output)"]
            raise InputError(f"building the FMUs failed: {lines[-1]}")
        if folder.exists():
            shutil.rmtree(folder, ignore_errors=True)  # an incomplete earlier build
        try:
            staging.rename(folder)
        except OSError:
            if not (folder / EKF_FMU).is_file():  # not another process that finished first
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
