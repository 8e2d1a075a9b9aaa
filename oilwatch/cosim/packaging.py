"""Stage an FMU's Python sources, and ship them compiled.

Staging (:func:`stage_sources`): the slave script goes to the top of ``resources/``, and
``resources/oilwatch/`` gets a minimal ``__init__.py``, the subpackages of
:data:`oilwatch.fmu_src.bundle.SUBPACKAGES` copied unchanged (the same set in every FMU, whatever its
slave imports) and ``bundle.json`` (version and source digest; the ``__init__.py`` holds it too as
``BUNDLE``). Nothing is renamed: every FMU's package is ``oilwatch``, and :mod:`oilwatch.fmu_src.bundle`
explains why two FMUs (or an FMU and a host that imported oilwatch) can share one, and what happens when
they cannot.

Shipping compiled code (:func:`ship_compiled`): a pythonfmu FMU runs its sources in the host's Python, so
whatever is compiled at run time (numba's kernels, Python's bytecode) is compiled again in every fresh
unpack, which is what most tools do on every run (seconds to tens of seconds of numba per FMU). The build
therefore runs the built FMU (FMI 2.0 or 3.0) once, in a fresh process under fmpy, unpacked into a temporary
folder: each instance of :data:`WARM_UP_RUNS` initializes and steps, so numba writes every kernel the FMU uses
into the ``__pycache__`` folders beside its sources. numba keys that cache by the source file's content (not
its path or time) and each entry by signature, CPU, Python minor version and numba version, so the entries
hit in any other unpack on a machine with the same CPU, Python minor and numba; elsewhere numba compiles as
before. Every module is then compiled to bytecode validated by a hash of its source (PEP 552, checked-hash
``.pyc``), which stays valid although an unpack gives the files new modification times. All these
``__pycache__`` files are added to the FMU, with the estimator's flowrate grids the run stored
(:mod:`oilwatch.fmu_src.grid_store`).

The warm-up's files depend only on the unpacked FMU's ``resources/`` (sources, machine file, tables), the
warm-up itself, the Python, numpy and numba versions and the CPU, so they are kept in
``<cache>/build/compiled/<key>/`` under a digest of all of these (:func:`compiled_key`) and a later build of
the same content adds them without running the FMU again (``OILWATCH_FMU_CACHE=0`` turns the store off, as
it does the unpacked folders; the :data:`KEEP_COMPILED` most recent are kept).

When the building process's own oilwatch has the FMU's sources byte for byte (:func:`installed_twin`: an
FMU built by ``oilwatch build-fmus`` from the installed package), the warm-up starts from the kernels that
oilwatch already compiled, and leaves those it compiles beside its sources too (:func:`copy_kernels`):
oilwatch's master runs the FMUs on that oilwatch (:mod:`oilwatch.fmu_src.bundle`), which would otherwise
compile them again on the first run.
"""

from __future__ import annotations

import compileall
import fnmatch
import hashlib
import json
import os
import py_compile
import shutil
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

from oilwatch.cosim.extraction import cache_root, persistent_extraction_enabled, prune
from oilwatch.fmu_src.bundle import BUNDLE_FILE, SUBPACKAGES, source_digest
from oilwatch.fmu_src.grid_store import GRID_FOLDER
from oilwatch.kernel_cache import INDEX_SUFFIX, NUMBA_SUFFIXES, OVERLOADS_SUFFIX
from oilwatch.models.machine import write_parsed_twin
from oilwatch.models.validation import InputError

ROOT_PACKAGE = "oilwatch"
BUNDLE_INIT = (
    '"""oilwatch as an FMU bundles it: the models, estimator and fmu_src subpackages."""\n\nBUNDLE = {}\n'
)
"""The bundled ``__init__.py``; ``BUNDLE`` is filled with the fingerprint (fmu_src/bundle.py reads it)."""
KEEP_COMPILED = 8
"""Warm-up results kept in ``<cache>/build/compiled`` (least recently used ones beyond this are deleted)."""
WARM_UP_STEPS = 200
WARM_UP_RUNS = (
    {},
    {"bearing_table": 1},
    {"q1_final_ml_min": 450.0, "q2_final_ml_min": 450.0, "fault_time_s": 0.05, "fault_duration_s": 0.05},
    {"preset": "paper"},
)
"""Parameter sets of the build's warm-up instances (one after the other, in one process), each used by the
FMUs that have all its parameters: the defaults, the dimensionless bearing table, a flowrate change within
the run (the plant's sub-stepped path) and the estimator's paper preset (the flowrate grid at one speed,
which the scenarios' SSP systems run)."""

WARM_UP = r"""
import json, sys
from fmpy import read_model_description

folder, runs, steps = sys.argv[1], json.loads(sys.argv[2]), int(sys.argv[3])
md = read_model_description(folder + "/modelDescription.xml")
variables = {v.name: v for v in md.modelVariables}
fmi3 = md.fmiVersion.startswith("3.")
if fmi3:
    from fmpy.fmi3 import FMU3Slave as Slave
else:
    from fmpy.fmi2 import FMU2Slave as Slave
for number, parameters in enumerate(runs):
    if not set(parameters) <= set(variables):
        continue
    fmu = Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier,
                instanceName=f"warm_up_{number}")
    fmu.instantiate()
    try:
        if fmi3:
            fmu.enterInitializationMode(startTime=0.0)
            setters, default = {"Int32": fmu.setInt32, "String": fmu.setString}, fmu.setFloat64
        else:
            fmu.setupExperiment(startTime=0.0)
            setters, default = {"Integer": fmu.setInteger, "String": fmu.setString}, fmu.setReal
        for name, value in parameters.items():
            v = variables[name]
            setters.get(v.type, default)([v.valueReference], [value])
        if not fmi3:
            fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        for k in range(steps):
            fmu.doStep(k * 1e-3, 1e-3)
        fmu.terminate()
    except Exception as error:  # a set-up this machine cannot run (no table for it): compiled on first use
        print(f"warm-up {parameters or 'defaults'} skipped: {error}", file=sys.stderr)
    fmu.freeInstance()
import oilwatch
print(oilwatch.__file__)
"""


def copy_package(
    source: Path, destination: Path, data_globs: tuple[str, ...], exclude: tuple[str, ...] = ()
) -> list[Path]:
    """Copy the ``*.py`` files and data files (``data_globs``) of a package tree; return them.

    ``__pycache__``, tests and files matching ``exclude`` (glob on the file name) are skipped.
    """
    if not (source / "__init__.py").is_file():
        raise InputError(f"package folder {source} does not exist or has no __init__.py")
    copied = []
    for path in sorted(source.rglob("*")):
        relative = path.relative_to(source)
        if not path.is_file() or "__pycache__" in relative.parts or "tests" in relative.parts:
            continue
        if any(fnmatch.fnmatch(path.name, pattern) for pattern in exclude):
            continue
        if path.suffix == ".py" or any(fnmatch.fnmatch(path.name, g) for g in data_globs):
            target = destination / relative
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(path, target)
            copied.append(target)
    return copied


def stage_sources(
    staging: Path, package_dirs: dict[str, Path], script: Path, version: str, data_globs: tuple[str, ...]
) -> tuple[Path, Path]:
    """Copy ``script`` to ``staging`` and the subpackages (``package_dirs``: name -> folder, installed or in
    a source tree, one per :data:`~oilwatch.fmu_src.bundle.SUBPACKAGES`) into ``staging/oilwatch`` with a
    minimal ``__init__.py`` and ``bundle.json`` (``version`` and the sources' digest).

    Returns the staged script and the staged ``oilwatch`` folder (pythonfmu's ``project_files``).
    """
    if set(package_dirs) != set(SUBPACKAGES):
        raise InputError(f"an FMU bundles exactly the subpackages {SUBPACKAGES}, got {tuple(package_dirs)}")
    root = staging / ROOT_PACKAGE
    root.mkdir(parents=True)
    staged_script = staging / script.name
    shutil.copy2(script, staged_script)
    for package, source in package_dirs.items():
        for copied in copy_package(source, root / package, data_globs):
            if copied.suffix == ".toml":  # the bundled machine files, readable on Python 3.10 too
                write_parsed_twin(copied)
    stamp = {"version": version, "digest": source_digest(root)}
    (root / BUNDLE_FILE).write_text(json.dumps(stamp) + "\n", encoding="utf-8")
    (root / "__init__.py").write_text(BUNDLE_INIT.replace("{}", repr(stamp)), encoding="utf-8")
    return staged_script, root


def _child_environment() -> dict[str, str]:
    """This environment without anything that would import another oilwatch or change the compiled code."""
    dropped = ("PYTHONPATH", "NUMBA_CACHE_DIR", "NUMBA_DISABLE_JIT", "OILWATCH_FMU_FAST_PATH")
    env = {key: value for key, value in os.environ.items() if key not in dropped}
    env.update(OPENBLAS_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    return env


def compiled_key(folder: Path) -> str:
    """The digest that names the warm-up's files of the FMU unpacked in ``folder``: every file under its
    ``resources/`` (path and bytes), the warm-up's script, instances and steps, and the Python, numpy and
    numba versions and the CPU numba compiles for."""
    import llvmlite.binding
    import numba
    import numpy

    digest = hashlib.sha256()
    resources = folder / "resources"
    for path in sorted(p for p in resources.rglob("*") if p.is_file() and "__pycache__" not in p.parts):
        digest.update(path.relative_to(resources).as_posix().encode() + b"\0")
        digest.update(hashlib.sha256(path.read_bytes()).digest())
    toolchain = (
        WARM_UP,
        WARM_UP_RUNS,
        WARM_UP_STEPS,
        sys.version,
        numpy.__version__,
        numba.__version__,
        llvmlite.binding.get_host_cpu_name(),
        llvmlite.binding.get_host_cpu_features().flatten(),
    )
    digest.update(json.dumps(toolchain, default=str).encode())
    return digest.hexdigest()


def _warm_up(folder: Path, label: str) -> list[Path]:
    """Run the FMU unpacked in ``folder`` once (module docstring) and compile its bytecode; return the
    files to ship: the ``__pycache__`` files of its bundled oilwatch and the grids the run stored."""
    command = [sys.executable, "-c", WARM_UP, str(folder), json.dumps(WARM_UP_RUNS), str(WARM_UP_STEPS)]
    process = subprocess.run(
        command, capture_output=True, text=True, cwd=folder.parent, env=_child_environment()
    )
    if process.returncode != 0:
        tail = (process.stderr or process.stdout).strip()[-2000:]
        raise InputError(f"{label}: the build's warm-up run failed: {tail}")
    bundled = folder / "resources" / ROOT_PACKAGE
    imported = Path(process.stdout.strip().splitlines()[-1]).resolve().parent
    if imported != bundled.resolve():
        raise InputError(f"{label}: the warm-up run imported oilwatch from {imported}, not from the FMU")
    for cache in bundled.rglob("__pycache__"):
        for stale in cache.glob("*.pyc"):  # checked by modification time: useless in another unpack
            stale.unlink()
    ok = compileall.compile_dir(
        bundled, quiet=1, invalidation_mode=py_compile.PycInvalidationMode.CHECKED_HASH
    )
    if not ok:
        raise InputError(f"{label}: compiling the bundled sources to bytecode failed")
    cached = sorted(p for p in bundled.rglob("*") if p.is_file() and p.parent.name == "__pycache__")
    return cached + sorted((folder / "resources" / GRID_FOLDER).glob("*.npz"))


def _store(files: list[Path], folder: Path, stored: Path) -> None:
    """Keep ``files`` (under ``folder``) as ``stored``, written whole or not at all."""
    stored.parent.mkdir(parents=True, exist_ok=True)
    partial = Path(tempfile.mkdtemp(prefix=".partial-", dir=stored.parent))
    try:
        for path in files:
            target = partial / path.relative_to(folder)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, target)
        os.replace(partial, stored)
    except OSError:  # another build stored the same key first, or the disk is full: the FMU is unaffected
        shutil.rmtree(partial, ignore_errors=True)
    prune(stored.parent, KEEP_COMPILED)


def add_members(fmu: Path, members: dict[str, bytes]) -> None:
    """Append ``members`` ({archive name: content}) to the FMU archive, as world-readable files."""
    if not members:
        return
    with zipfile.ZipFile(fmu, "a", zipfile.ZIP_DEFLATED) as archive:
        for name, content in members.items():
            entry = zipfile.ZipInfo(name, date_time=time.localtime()[:6])
            entry.external_attr = 0o644 << 16
            archive.writestr(entry, content, zipfile.ZIP_DEFLATED)


def _stored_files(stored: Path) -> dict[str, bytes] | None:
    """{archive name: content} of an earlier warm-up kept as ``stored``; None when there is none (or it
    was pruned while being read)."""
    if not stored.is_dir():
        return None
    try:
        os.utime(stored)  # the most recently used: the last to be pruned
        return {
            p.relative_to(stored).as_posix(): p.read_bytes() for p in sorted(stored.rglob("*")) if p.is_file()
        }
    except OSError:
        return None


def ship_compiled(fmu: Path, label: str, seed: Path | None = None) -> bool:
    """Add the compiled kernels and bytecode of ``fmu``'s bundled oilwatch to it (module docstring); True
    when they came from an earlier build's warm-up of the same content, False when this build ran it.
    ``seed``: an FMU built from the same sources that already ships its kernels (the FMI 2.0 twin of an
    FMI 3.0 FMU): its numba files are put beside the sources before the warm-up, which then loads what
    they hold instead of compiling it (numba checks each against the source's content)."""
    fmu = Path(fmu)
    with tempfile.TemporaryDirectory(prefix="oilwatch_warm_up_") as tmp:
        folder = Path(tmp) / "fmu"
        with zipfile.ZipFile(fmu) as archive:
            archive.extractall(folder)
        keep = persistent_extraction_enabled()
        stored = cache_root() / "build" / "compiled" / compiled_key(folder) if keep else None
        shipped = _stored_files(stored) if stored is not None else None
        reused = shipped is not None
        if not reused:
            if seed is not None:
                _seed_kernels(folder, Path(seed))
            bundled = folder / "resources" / ROOT_PACKAGE
            installed = installed_twin(bundled)
            if installed is not None:
                copy_kernels(installed, bundled)
            files = _warm_up(folder, label)
            if installed is not None:  # this oilwatch runs the FMUs it hosts: their kernels, compiled
                copy_kernels(bundled, installed)
            shipped = {path.relative_to(folder).as_posix(): path.read_bytes() for path in files}
            if stored is not None:
                _store(files, folder, stored)
        add_members(fmu, shipped)
    return reused


def _seed_kernels(folder: Path, seed: Path) -> None:
    """Copy the numba files of ``seed``'s bundled oilwatch into the FMU unpacked in ``folder``. numba keeps
    an entry only while its source file's content is the one it was compiled from: a kernel whose source
    differs between the two is compiled again, as without the seed."""
    prefix = f"resources/{ROOT_PACKAGE}/"
    with zipfile.ZipFile(seed) as archive:
        for name in archive.namelist():
            if name.startswith(prefix) and "/__pycache__/" in name:
                if name.endswith(NUMBA_SUFFIXES):
                    target = folder / name
                    target.parent.mkdir(parents=True, exist_ok=True)
                    target.write_bytes(archive.read(name))


def installed_twin(bundled: Path) -> Path | None:
    """The oilwatch folder this process imported when its subpackages hold the sources of ``bundled`` (an
    FMU's oilwatch) byte for byte, else None.

    Such a process runs an FMU it loads on its own oilwatch (:mod:`oilwatch.fmu_src.bundle`), with the
    kernels numba cached beside its own sources; and numba keys them by the source's content, so the two
    folders' kernels serve each other."""
    import oilwatch

    installed = Path(oilwatch.__file__).parent
    try:
        recorded = json.loads((bundled / BUNDLE_FILE).read_text(encoding="utf-8"))["digest"]
    except (OSError, ValueError, KeyError):
        return None
    return installed if source_digest(installed) == recorded else None


def copy_kernels(source: Path, target: Path) -> int:
    """Copy numba's cache files of each kernel cached under ``source`` (an oilwatch folder) to the same
    place under ``target`` (one with the same sources, :func:`installed_twin`) where ``target`` has none
    for it: its overloads, then its index, so that no reader meets an index without them. A folder that
    cannot be written is left as it is. Returns the number of kernels copied."""
    copied = 0
    for package in SUBPACKAGES:
        for folder, _, names in os.walk(source / package, followlinks=True):
            if Path(folder).name != "__pycache__":
                continue
            destination = target / Path(folder).relative_to(source)
            for index in (name for name in names if name.endswith(INDEX_SUFFIX)):
                if (destination / index).exists():
                    continue
                stem = index[: -len(INDEX_SUFFIX)]
                data = [n for n in names if n.startswith(stem + ".") and n.endswith(OVERLOADS_SUFFIX)]
                try:
                    destination.mkdir(parents=True, exist_ok=True)
                    for name in (*data, index):
                        partial = destination / f".{name}.{os.getpid()}"
                        shutil.copyfile(Path(folder, name), partial)
                        os.replace(partial, destination / name)
                except OSError:
                    return copied
                copied += 1
    return copied


def share_compiled(fmus: list[Path]) -> None:
    """Give each of ``fmus`` the compiled files (``__pycache__`` of its bundled oilwatch) that the others of
    the same bundle have and it lacks.

    Two FMUs in one process share one ``oilwatch``, imported from the folder of the first that loads
    (:mod:`oilwatch.fmu_src.bundle`): the estimator's kernels then come from the plant's folder, whose own
    warm-up never compiled them, so without them a host that loads the plant first (libcosim, most tools)
    compiles the estimator on first use. The bundled sources are the same, so are numba's keys.
    """
    compiled: dict[bytes, dict[str, bytes]] = {}
    bundles = {}
    prefix = f"resources/{ROOT_PACKAGE}/"
    for fmu in fmus:
        with zipfile.ZipFile(fmu) as archive:
            bundle = archive.read(prefix + BUNDLE_FILE)
            bundles[fmu] = bundle
            known = compiled.setdefault(bundle, {})
            for name in archive.namelist():
                if name.startswith(prefix) and "/__pycache__/" in name and name not in known:
                    known[name] = archive.read(name)
    for fmu in fmus:
        with zipfile.ZipFile(fmu) as archive:
            present = set(archive.namelist())
        add_members(fmu, {name: data for name, data in compiled[bundles[fmu]].items() if name not in present})
