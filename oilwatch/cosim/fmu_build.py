"""Build oilwatch's FMI 2.0 co-simulation FMUs (pythonfmu) and the SSP system from the installed package.

``oilwatch build-fmus [--machine FILE] [--out DIR] [--only NAME ...]`` (and ``python build.py``, a thin
wrapper in a source tree) builds every FMU in :data:`REGISTRY` (or only the named ones) into ``--out``:
``RotorBearingPlant.fmu`` (slave ``fmu_src/oilwatch_plant_slave.py``) and ``OilFlowEKF.fmu`` (slave
``fmu_src/oilwatch_ekf_slave.py``), then each SSP system whose FMUs were all built: ``OilStarvation.ssp``
(the sudden-drop scenario of that machine, plant and estimator connected by name, SSP 1.0, see
:mod:`oilwatch.cosim.ssp`). Everything comes from the importable packages (``models``, ``estimator``,
``fmu_src``), wherever they are installed: no source tree is needed.

For each FMU (see :func:`assemble_fmu`, then :func:`build_fmus`):

1. Staging: the slave script and ``oilwatch/`` (a minimal ``__init__.py``, the ``models``, ``estimator`` and
   ``fmu_src`` subpackages unchanged, the same in every FMU, and ``bundle.json``) are copied to a temporary
   folder (:mod:`oilwatch.cosim.packaging`; :mod:`oilwatch.fmu_src.bundle` says why FMUs in one process can
   share that package). The data files the packages carry (``*.toml``, ``*.json``, or the entry's
   ``data_globs``) are bundled too; code must find them with ``Path(__file__).parent``.
2. The machine: its file and every table of it (``tables/<stem>_*.json`` beside it, and for the bundled
   turbine also the user cache's) are copied into ``oilwatch/fmu_src/machine/``; the FMU's empty
   ``machine_file`` parameter means this machine, found through the instance's own resources folder
   (:mod:`oilwatch.fmu_src.machine_parameters`).
3. pythonfmu's ``FmuBuilder.build_FMU`` builds the FMU from the staging folder, with the entry's FMI
   capability flags (by default ``canGetAndSetFMUstate`` and ``canSerializeFMUstate``).
4. The binaries: ``binaries/linux64/<name>.so`` becomes oilwatch's loader
   (:mod:`oilwatch.cosim.native_loader`);
   pythonfmu's other platforms' binaries (its stock Windows and macOS libraries, which hold none of the
   loader and are not tested) are removed, so the FMU claims Linux x86-64 only.
5. The compiled code: the FMU runs once in a fresh process, and numba's kernels and the bytecode go into the
   archive (:func:`oilwatch.cosim.packaging.ship_compiled`), unless the entry says ``ship_compiled=False``;
   once all FMUs of the call are built, each gets the others' too
   (:func:`oilwatch.cosim.packaging.share_compiled`).
6. ``documentation/index.html`` (variables with causality, unit, min, max, start, description, and fmpy
   examples) is added to the archive.
7. ``fmpy.validation.validate_fmu`` must report no problem, else the build fails.

The slave class name must equal the entry's ``name`` (it becomes the model identifier). Other code (tests,
benchmarks) builds extra FMUs with the same machinery by passing its own :class:`FmuEntry` list to
:func:`build_fmus` (``extra=``). Exit codes: 0 success, 2 bad input (unknown name, missing slave script,
a failed warm-up run, invalid FMU, bad machine file).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import shutil
import sys
import tempfile
import zipfile
from dataclasses import dataclass, field, replace
from pathlib import Path

from oilwatch.fmu_src.bundle import SUBPACKAGES as FMU_PACKAGES
from oilwatch.models.system.factory import machine_files
from oilwatch.models.validation import InputError

DEFAULT_OPTIONS = {"canGetAndSetFMUstate": True, "canSerializeFMUstate": True}
PLATFORM_FOLDER = "binaries/linux64/"


def package_dir(package: str) -> Path:
    """The folder of an importable top-level package (installed or in a source tree)."""
    spec = importlib.util.find_spec(f"oilwatch.{package}")
    if spec is None or not spec.submodule_search_locations:
        raise InputError(f"package {package!r} is not importable: install oilwatch")
    return Path(next(iter(spec.submodule_search_locations))).resolve()


def package_root() -> Path:
    """The folder holding the ``models``, ``estimator`` and ``fmu_src`` packages (site-packages, a clone)."""
    return package_dir("fmu_src").parent


@dataclass(frozen=True)
class FmuEntry:
    """One FMU to build.

    name: model identifier and file stem (``<name>.fmu``); the slave class must be called so.
    script: the slave script, relative to :func:`package_root` (or absolute).
    data_globs: data files bundled with the packages.
    options: pythonfmu/FMI capability flags written into ``<CoSimulation>``.
    ship_compiled: run the built FMU once and add its compiled kernels and bytecode (step 5 above).
    """

    name: str
    script: str
    data_globs: tuple[str, ...] = ("*.toml", "*.json")
    options: dict = field(default_factory=lambda: dict(DEFAULT_OPTIONS))
    ship_compiled: bool = True

    def script_path(self, root: Path | None = None) -> Path:
        path = Path(self.script)
        return path if path.is_absolute() else (root or package_root()) / path


REGISTRY: tuple[FmuEntry, ...] = (
    FmuEntry(
        name="RotorBearingPlant",
        script="fmu_src/oilwatch_plant_slave.py",
    ),
    FmuEntry(
        name="OilFlowEKF",
        script="fmu_src/oilwatch_ekf_slave.py",
    ),
)


@dataclass(frozen=True)
class SspEntry:
    """An SSP system written after its FMUs are built: ``<name>.ssp`` in the output folder.

    components: (instance name, FMU name in the registry, parameter values) per FMU instance.
    Connections are made by name (each input from the same-named output). stop_time and
    step_size [s] form the default experiment.
    """

    name: str
    components: tuple[tuple[str, str, dict], ...]
    stop_time: float
    step_size: float


def scenario_system(machine=None, scenario: str = "sudden-drop", name: str = "OilStarvation") -> SspEntry:
    """The SSP system of one of the paper's scenarios on ``machine`` (default: the bundled turbine).

    OilStarvation: the sudden drop (``oilwatch run sudden-drop``): both supply flowrates 100 -> 75 % of each
    bearing's nominal, 0.1 s 10-90 % transition centred at 10 s of 20 s, 1 um noise, the machine file's
    unbalance on both sides, each FMU on the machine it bundles (``machine_file`` empty). Connected by name:
    x1_um..y2_um and t_sample_s (the sample time stamp that keeps the estimator aligned under any master's
    ordering). The bindings are the scenario's own parameters, not retyped.
    """
    from oilwatch.scenarios import SAMPLE_PERIOD_S, make_run

    run = replace(make_run(scenario, machine=machine), machine_file="")
    unbalance = {"unbalance_g_mm": -1.0, "unbalance_phase_deg": 0.0}
    return SspEntry(
        name=name,
        components=(
            ("plant", "RotorBearingPlant", {**run.plant_parameters(), **unbalance}),
            ("ekf", "OilFlowEKF", {**run.ekf_parameters(), **unbalance}),
        ),
        stop_time=run.duration_s,
        step_size=SAMPLE_PERIOD_S,
    )


def write_system(entry: SspEntry, fmus: dict[str, Path], out_dir: Path) -> Path:
    """Write ``entry`` as ``<out_dir>/<name>.ssp`` from the built ``fmus`` (name -> path)."""
    from oilwatch.cosim import FmuSpec, SystemDescription
    from oilwatch.cosim.ssp import write_ssp

    system = SystemDescription(
        [FmuSpec(instance, fmus[fmu], dict(values)) for instance, fmu, values in entry.components],
        connections=None,
        stop_time=entry.stop_time,
        step_size=entry.step_size,
        name=entry.name,
    )
    return write_ssp(out_dir / f"{entry.name}.ssp", system)


def bundle_machine(machine, fmu_src_folder: Path) -> None:
    """Copy the machine file (and its parsed twin, :data:`oilwatch.models.machine.PARSED_TWIN_SUFFIX`) to
    ``<fmu_src_folder>/machine/`` and its tables to ``machine/tables/``."""
    from oilwatch.fmu_src.machine_parameters import MACHINE_FOLDER
    from oilwatch.models.machine import write_parsed_twin

    target = fmu_src_folder / MACHINE_FOLDER
    (target / "tables").mkdir(parents=True, exist_ok=True)
    source, *tables = machine_files(machine)
    shutil.copy2(source, target / source.name)
    write_parsed_twin(target / source.name)
    for table in tables:
        shutil.copy2(table, target / "tables" / table.name)


def _forget_modules(names: set[str]) -> None:
    """Drop staged modules from this process so a later build cannot pick up stale code."""
    for module in list(sys.modules):
        if module.split(".", 1)[0] in names:
            del sys.modules[module]


def oilwatch_version() -> str:
    """The installed oilwatch's version (``unknown`` for a source tree without metadata)."""
    from importlib import metadata

    try:
        return metadata.version("oilwatch")
    except metadata.PackageNotFoundError:
        return "unknown"


def keep_platform(fmu: Path, folder: str = PLATFORM_FOLDER) -> None:
    """Remove every binary of ``fmu`` outside ``folder`` (pythonfmu's stock binaries of other platforms)."""
    with zipfile.ZipFile(fmu) as source:
        dropped = [n for n in source.namelist() if n.startswith("binaries/") and not n.startswith(folder)]
        if not dropped:
            return
        rewritten = fmu.with_name(f".{fmu.name}.partial")
        with zipfile.ZipFile(rewritten, "w", zipfile.ZIP_DEFLATED) as target:
            for info in source.infolist():
                if info.filename not in dropped:
                    target.writestr(info, source.read(info))
    rewritten.replace(fmu)


def assemble_fmu(entry: FmuEntry, private: Path, machine=None, root: Path | None = None) -> Path:
    """Build ``entry``'s FMU for ``machine`` (default: the bundled turbine) into the folder ``private``, with
    its loader and, unless the entry says otherwise, its compiled code; return its path."""
    from pythonfmu.builder import FmuBuilder

    from oilwatch.cosim.native_loader import install_loader
    from oilwatch.cosim.packaging import ship_compiled, stage_sources
    from oilwatch.models.machine import load_machine

    machine = machine if machine is not None else load_machine()
    script = entry.script_path(root)
    if not script.is_file():
        raise InputError(f"{entry.name}: slave script {script} does not exist")
    folders_of = {package: package_dir(package) for package in FMU_PACKAGES}
    private_fmu = private / f"{entry.name}.fmu"
    with tempfile.TemporaryDirectory(prefix=f"oilwatch_{entry.name}_") as tmp:
        staging = Path(tmp)
        staged_script, bundled = stage_sources(
            staging, folders_of, script, oilwatch_version(), entry.data_globs
        )
        bundle_machine(machine, bundled / "fmu_src")
        saved_path = list(sys.path)
        try:
            built = FmuBuilder.build_FMU(
                staged_script, dest=private_fmu, project_files=[bundled], **entry.options
            )
        finally:
            sys.path[:] = saved_path
            _forget_modules({script.stem})
    built = Path(built)
    with zipfile.ZipFile(built) as archive:
        identifier = archive.read("resources/slavemodule.txt").decode().strip()
        names = archive.namelist()
    if not any(n == f"{PLATFORM_FOLDER}{entry.name}.so" for n in names):
        raise InputError(
            f"{entry.name}: the slave class in {script.name} must be named {entry.name} "
            f"(pythonfmu names the model after the class; module {identifier})"
        )
    install_loader(built, entry.name)  # self-sufficient binary: oilwatch/cosim/native_loader.py
    keep_platform(built)
    if entry.ship_compiled:
        ship_compiled(built, entry.name)
    return built


def document_and_validate(built: Path, label: str) -> Path:
    """Add ``documentation/index.html`` (the FMU's variable tables) to the built FMU and run ``fmpy
    validate`` on it (InputError naming ``label`` and the problems); return ``built``."""
    from fmpy.validation import validate_fmu

    from .fmu_docs import documentation_html

    with zipfile.ZipFile(built, "a") as archive:
        archive.writestr("documentation/index.html", documentation_html(built))
    problems = validate_fmu(str(built))
    if problems:
        raise InputError(f"{label}: fmpy validate found problems: " + "; ".join(problems))
    return built


def build_fmus(
    out_dir: Path | str = "build",
    only: list[str] | None = None,
    extra: tuple[FmuEntry, ...] | list[FmuEntry] = (),
    root: Path | None = None,
    registry: tuple[FmuEntry, ...] = REGISTRY,
    systems: tuple[SspEntry, ...] | None = None,
    machine=None,
) -> list[Path]:
    """Build the registered FMUs (plus ``extra``), or only those named in ``only``, for ``machine`` (a
    :class:`oilwatch.models.machine.Machine` or a machine file; default: the bundled turbine), then every SSP
    system of ``systems`` (default: the machine's OilStarvation) whose FMUs were all built in this call.
    Returns the files written."""
    from oilwatch.cosim.packaging import share_compiled
    from oilwatch.models.machine import Machine, load_machine
    from oilwatch.outputs.atomic import commit

    if not isinstance(machine, Machine):
        machine = load_machine(machine)
    entries = {entry.name: entry for entry in (*registry, *extra)}
    if only:
        unknown = [name for name in only if name not in entries]
        if unknown:
            raise InputError(f"--only: unknown FMU {unknown}; known: {sorted(entries)}")
        selected = [entries[name] for name in only]
    else:
        selected = list(entries.values())
    missing = [str(e.script_path(root)) for e in selected if not e.script_path(root).is_file()]
    if missing:
        raise InputError(f"slave script(s) missing: {missing}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    # Each FMU is built, given its loader and validated in a private folder beside its target, then renamed:
    # it appears under its name whole and valid or not at all, and two builders never rewrite one file (the
    # loader installed twice over one FMU made the loader its inner binary).
    with contextlib.ExitStack() as stack:
        assembled = {}
        for entry in selected:
            private = stack.enter_context(
                tempfile.TemporaryDirectory(prefix=f".{entry.name}.", suffix=".partial", dir=out)
            )
            assembled[entry.name] = assemble_fmu(entry, Path(private), machine, root)
        share_compiled([assembled[e.name] for e in selected if e.ship_compiled])
        built = {
            name: commit(document_and_validate(path, name), out / f"{name}.fmu")
            for name, path in assembled.items()
        }
    written = list(built.values())
    for system in (scenario_system(machine),) if systems is None else systems:
        if all(fmu in built for _, fmu, _ in system.components):
            written.append(write_system(system, built, Path(out_dir)))
    return written


def build_in_subprocess(out_dir: Path | str, machine_file: str | Path | None = None, only=None) -> str:
    """Run :func:`main` in a fresh Python process (building imports the slave modules, which must not
    linger in the caller); return its output. An InputError carries the build's last error line."""
    import subprocess

    command = [sys.executable, "-c", "import sys; from oilwatch.cosim.fmu_build import main; "
               "sys.exit(main(sys.argv[1:], 'oilwatch build-fmus'))", "--out", str(out_dir)]  # fmt: skip
    if machine_file is not None:
        command += ["--machine", str(machine_file)]
    if only:
        command += ["--only", *only]
    process = subprocess.run(command, capture_output=True, text=True)
    if process.returncode != 0:
        lines = (process.stderr or process.stdout).strip().splitlines() or ["(no output)"]
        raise InputError(lines[-1].removeprefix("oilwatch build-fmus: error: "))
    return process.stdout


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``oilwatch build-fmus`` and ``build.py``."""
    parser.add_argument("--out", default="build", metavar="DIR", help="output folder (default: build)")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="build only these FMUs")
    parser.add_argument(
        "--machine",
        metavar="FILE",
        default=None,
        help="machine file the FMUs bundle, with its tables (default: the bundled generic turbine)",
    )


def main(argv: list[str] | None = None, prog: str = "build.py") -> int:
    """``build.py``'s command line (``oilwatch build-fmus`` shares :func:`add_arguments`)."""
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        for path in build_fmus(args.out, args.only, machine=args.machine):
            print(f"built {path}")
    except InputError as error:
        print(f"{prog}: error: {error}", file=sys.stderr)
        return 2
    except OSError as error:  # a full or read-only disk: one line naming the path; nothing half-built kept
        from oilwatch.outputs.rows import describe_os_error

        where = error.filename or args.out
        print(f"{prog}: error: cannot write {where}: {describe_os_error(error)}; the file being built "
              "was removed, every FMU or SSP under its final name is whole and validated",
              file=sys.stderr)  # fmt: skip
        return 2
    return 0
