"""Build the FMI 3.0 co-simulation twins of oilwatch's FMUs with pythonfmu3.

Each FMI 3.0 FMU is the FMI 2.0 slave of the same name behind :class:`oilwatch.fmu_src.fmi3_shell.Fmi3Shell`:
the shell script (``fmu_src/*_fmi3_slave.py``) is staged like an FMI 2.0 slave (``oilwatch/`` with the same
subpackages, see :mod:`oilwatch.cosim.packaging`; the FMI 2.0 slave script it wraps is part of
``oilwatch/fmu_src``), together with pythonfmu itself (the FMI 2.0 slave's base class).
pythonfmu3 writes the model description; ``documentation/index.html`` is added and ``fmpy validate`` must
pass, as for FMI 2.0.

The binaries are pythonfmu3's own, behind a thin layer (``native/fmi3_refusal.c``) that answers a refused
input (a parameter out of range at initialization, a fixed parameter set after it) with fmi3Error instead of
pythonfmu3's fmi3Fatal, as the FMI 2.0 loader does, and releases pythonfmu3's interpreter guard at exit
(its binary has pythonfmu 0.7's teardown defect, as the FMI 2.0 loader's notes say). They need a host that
already runs Python (fmpy, libcosimpy); the self-sufficient loader exists for FMI 2.0 only
(``native/fmi2_loader.c``). pythonfmu3's Windows binary is removed: only ``x86_64-linux`` is built and tested.
The compiled code ships as in FMI 2.0 (:func:`oilwatch.cosim.packaging.ship_compiled`: the build runs each
FMU once under fmpy.fmi3 and adds numba's kernels, the bytecode and the estimator's grids), so a fresh unpack
initializes without compiling. The FMI 2.0 FMUs of the systems given to :func:`build_fmi3_fmus` seed that run
with the kernels they ship (the same sources), so it compiles none of them again: the FMI 3.0 pair's build
took 14 s of CPU instead of 73 s with nothing stored.
"""

from __future__ import annotations

import contextlib
import shutil
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from oilwatch.models.validation import InputError

from .fmu_build import REGISTRY, FmuEntry
from .native_loader import FMI3_PLATFORM, install_fmi3_refusal
from .packaging import share_compiled, ship_compiled, stage_sources

FMI3_OPTIONS = {"canGetAndSetFMUState": True, "canSerializeFMUState": True}
BINARY = "binaries/x86_64-linux/{name}.so"


@dataclass(frozen=True)
class Fmi3Entry:
    """One FMI 3.0 FMU: ``name`` (model identifier, the shell's class name), the shell ``script``, the
    FMI 2.0 slave script it wraps and the data files to bundle."""

    name: str
    script: str
    fmi2_script: str
    data_globs: tuple[str, ...] = ("*.toml", "*.json")


def fmi3_entry(entry: FmuEntry, script: str) -> Fmi3Entry:
    """The FMI 3.0 twin of the FMI 2.0 ``entry``: its shell ``script`` wrapping ``entry.script``, the same
    data."""
    return Fmi3Entry(entry.name, script, entry.script, entry.data_globs)


FMI3_SCRIPTS = {
    "RotorBearingPlant": "fmu_src/oilwatch_plant_fmi3_slave.py",
    "OilFlowEKF": "fmu_src/oilwatch_ekf_fmi3_slave.py",
}
"""The FMI 3.0 shell script of each FMU of :data:`~oilwatch.cosim.fmu_build.REGISTRY`."""

FMI3_REGISTRY: tuple[Fmi3Entry, ...] = tuple(fmi3_entry(e, FMI3_SCRIPTS[e.name]) for e in REGISTRY)


def build_fmi3_fmu(entry: Fmi3Entry, out_dir: Path, machine=None, fmi2_twin: Path | None = None) -> Path:
    """Build one FMI 3.0 FMU into ``out_dir`` for ``machine`` (default: the bundled turbine); return its path
    (see the module docstring). ``fmi2_twin``: the FMI 2.0 build of the same slave, whose shipped kernels
    the warm-up loads instead of compiling them again."""
    import pythonfmu
    from pythonfmu3.builder import FmuBuilder

    from oilwatch.models.machine import load_machine

    from .fmu_build import (
        FMU_PACKAGES,
        _forget_modules,
        bundle_machine,
        document_and_validate,
        keep_platform,
        oilwatch_version,
        package_dir,
        package_root,
    )

    machine = machine if machine is not None else load_machine()
    script, fmi2_script = package_root() / entry.script, package_root() / entry.fmi2_script
    for path in (script, fmi2_script):
        if not path.is_file():
            raise InputError(f"{entry.name} (FMI 3.0): slave script {path} does not exist")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=f"oilwatch_fmi3_{entry.name}_") as tmp:
        staging = Path(tmp)
        folders_of = {package: package_dir(package) for package in FMU_PACKAGES}
        staged_script, bundled = stage_sources(
            staging, folders_of, script, oilwatch_version(), entry.data_globs
        )
        bundle_machine(machine, bundled / "fmu_src")
        fmi2_base = staging / "pythonfmu"  # its Python files, as pythonfmu's own builder bundles them
        fmi2_base.mkdir()
        for module in Path(pythonfmu.__file__).parent.glob("*.py"):
            shutil.copy2(module, fmi2_base)
        saved_path = list(sys.path)
        try:
            built = FmuBuilder.build_FMU(
                staged_script, dest=out_dir, project_files=[bundled, fmi2_base], **FMI3_OPTIONS
            )
        finally:
            sys.path[:] = saved_path
            _forget_modules({script.stem, "pythonfmu"})
    built = Path(built)
    with zipfile.ZipFile(built) as archive:
        if BINARY.format(name=entry.name) not in archive.namelist():
            built.unlink()
            raise InputError(f"{entry.name}: the class in {script.name} must be named {entry.name}")
    install_fmi3_refusal(built, entry.name)  # refused input: fmi3Error (oilwatch/cosim/native_loader.py)
    keep_platform(built, f"binaries/{FMI3_PLATFORM}/")  # pythonfmu3's Windows binary is not tested
    ship_compiled(built, f"{entry.name} (FMI 3.0)", seed=fmi2_twin)
    return document_and_validate(built, f"{entry.name} (FMI 3.0)")


def _model_identifier(fmu: Path) -> str:
    """The co-simulation model identifier of the FMU file ``fmu``."""
    from fmpy import read_model_description

    return read_model_description(str(fmu), validate=False).coSimulation.modelIdentifier


def fmi3_system(fmi2_ssp: Path, fmus: dict[str, Path], out_dir: Path) -> Path:
    """Write the FMI 3.0 twin of the FMI 2.0 system ``fmi2_ssp`` into ``out_dir`` (same file name): same
    instances, parameter bindings, connections and experiment, each FMU replaced by its FMI 3.0 build
    (``fmus``: model identifier -> FMI 3.0 FMU)."""
    from .ssp import open_ssp, write_ssp

    with open_ssp(fmi2_ssp) as system:
        for spec in system.fmus:
            identifier = _model_identifier(spec.path)
            if identifier not in fmus:
                raise InputError(f"{fmi2_ssp}: no FMI 3.0 build of {identifier} (instance {spec.name})")
            spec.path = fmus[identifier]
        return write_ssp(Path(out_dir) / Path(fmi2_ssp).name, system)


def build_fmi3_fmus(
    out_dir: Path | str,
    fmi2_systems: list[Path] = (),
    registry: tuple[Fmi3Entry, ...] = FMI3_REGISTRY,
    machine=None,
) -> list[Path]:
    """Build every entry of ``registry`` into ``out_dir`` (FMI 3.0) for ``machine`` (default: the bundled
    turbine), then the FMI 3.0 twin of each FMI 2.0 SSP of ``fmi2_systems``; return the files written. The
    FMI 2.0 FMUs of those systems seed the warm-up of their FMI 3.0 twins (:func:`build_fmi3_fmu`)."""
    from .ssp import open_ssp

    with contextlib.ExitStack() as stack:
        twins: dict[str, Path] = {}
        for ssp in fmi2_systems:
            for spec in stack.enter_context(open_ssp(ssp)).fmus:
                twins.setdefault(_model_identifier(spec.path), Path(spec.path))
        fmus = {
            entry.name: build_fmi3_fmu(entry, Path(out_dir), machine, twins.get(entry.name))
            for entry in registry
        }
    share_compiled(list(fmus.values()))
    return [*fmus.values(), *(fmi3_system(Path(ssp), fmus, Path(out_dir)) for ssp in fmi2_systems)]
