"""Build oilwatch's FMI 2.0 co-simulation FMUs with pythonfmu.

Usage::

    python build.py [--out build] [--only NAME ...]

builds every FMU in :data:`REGISTRY` (or only the named ones) into ``--out``:
``RotorBearingPlant.fmu`` (slave ``fmu_src/oilwatch_plant_slave.py``) and ``OilFlowEKF.fmu``
(slave ``fmu_src/oilwatch_ekf_slave.py``), then each SSP system of :data:`SYSTEMS` whose FMUs were
all built: ``OilStarvation.ssp`` (plant and estimator connected by name, SSP 1.0, see
:mod:`oilwatch.cosim.ssp`).

For each FMU (see :func:`build_fmu`):

1. Staging: the slave script and the packages it needs (``models``, ``estimator``, ``fmu_src``)
   are copied to a temporary folder, each package renamed ``<prefix>_<package>`` (for example
   ``oilwatch_plant_models``) and every ``from models... import`` rewritten to match
   (:mod:`oilwatch.cosim.packaging`). Two FMUs in one process therefore share no module name. An
   ``import models`` form, which cannot be relocated, fails the build with file and line. The data
   files the packages carry (``*.toml``, ``*.json``, or the entry's ``data_globs``) are bundled
   too; code must find them with ``Path(__file__).parent``, never by package name.
2. pythonfmu's ``FmuBuilder.build_FMU`` builds the FMU from the staging folder, with the entry's
   FMI capability flags (by default ``canGetAndSetFMUstate`` and ``canSerializeFMUstate``).
3. ``documentation/index.html`` (variables with causality, unit, min, max, start, description,
   and fmpy examples) is added to the archive.
4. ``fmpy.validation.validate_fmu`` must report no problem, else the build fails.
5. After all FMUs: the SSP systems (an unknown parameter or connector fails the build).

The slave class name must equal the entry's ``name`` (it becomes the model identifier). Other
code (tests, benchmarks) builds extra FMUs with the same machinery by passing its own
:class:`FmuEntry` list to :func:`build_fmus` (``extra=``).

Exit codes: 0 success, 2 bad input (unknown name, missing slave script, relocation error, invalid
FMU).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from models.validation import InputError  # noqa: E402

DEFAULT_OPTIONS = {"canGetAndSetFMUstate": True, "canSerializeFMUstate": True}


@dataclass(frozen=True)
class FmuEntry:
    """One FMU to build.

    name: model identifier and file stem (``<name>.fmu``); the slave class must be called so.
    script: the slave script, relative to the repository root (or absolute).
    packages: top-level packages to bundle, relocated as ``<prefix>_<package>``.
    prefix: relocation prefix, unique per FMU (for example ``oilwatch_plant``).
    data_globs: data files bundled with the packages.
    options: pythonfmu/FMI capability flags written into ``<CoSimulation>``.
    """

    name: str
    script: str
    packages: tuple[str, ...]
    prefix: str
    data_globs: tuple[str, ...] = ("*.toml", "*.json")
    options: dict = field(default_factory=lambda: dict(DEFAULT_OPTIONS))

    def script_path(self, root: Path = REPO_ROOT) -> Path:
        path = Path(self.script)
        return path if path.is_absolute() else root / path


REGISTRY: tuple[FmuEntry, ...] = (
    FmuEntry(
        name="RotorBearingPlant",
        script="fmu_src/oilwatch_plant_slave.py",
        packages=("models", "fmu_src"),
        prefix="oilwatch_plant",
    ),
    FmuEntry(
        name="OilFlowEKF",
        script="fmu_src/oilwatch_ekf_slave.py",
        packages=("models", "estimator", "fmu_src"),
        prefix="oilwatch_ekf",
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


# OilStarvation: the paper's sudden drop (``oilwatch run sudden-drop``; tests/test_cosim_scenarios.py
# checks these bindings against oilwatch.scenarios): both supply flowrates 596.3 -> 447.225 ml/min
# (100 -> 75 %), 0.1 s 10-90 % transition centred at 10 s of 20 s, 1 um noise, the bundled turbine's
# unbalance on both sides. Connected by name: x1_um..y2_um and t_sample_s (the sample time stamp that
# keeps the estimator aligned under any master's ordering).
SYSTEMS: tuple[SspEntry, ...] = (
    SspEntry(
        name="OilStarvation",
        components=(
            (
                "plant",
                "RotorBearingPlant",
                {
                    "speed_hz": 75.0,
                    "q1_initial_ml_min": 596.3,
                    "q1_final_ml_min": 447.225,
                    "q2_initial_ml_min": 596.3,
                    "q2_final_ml_min": 447.225,
                    "fault_time_s": 10.0,
                    "fault_duration_s": 0.1,
                    "noise_um": 1.0,
                    "seed": 1,
                    "unbalance_g_mm": -1.0,
                    "unbalance_phase_deg": 0.0,
                },
            ),
            (
                "ekf",
                "OilFlowEKF",
                {
                    "speed_hz": 75.0,
                    "noise_um": 1.0,
                    "q_initial_ml_min": 596.3,
                    "q_nominal_ml_min": 596.3,
                    "unbalance_g_mm": -1.0,
                    "unbalance_phase_deg": 0.0,
                },
            ),
        ),
        stop_time=20.0,
        step_size=1e-3,
    ),
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


def _forget_modules(names: set[str]) -> None:
    """Drop staged modules from this process so a later build cannot pick up stale code."""
    for module in list(sys.modules):
        if module.split(".", 1)[0] in names:
            del sys.modules[module]


def build_fmu(entry: FmuEntry, out_dir: Path, root: Path = REPO_ROOT) -> Path:
    """Build one FMU into ``out_dir`` and return its path (see the module docstring)."""
    from fmpy.validation import validate_fmu
    from pythonfmu.builder import FmuBuilder

    from oilwatch.cosim.fmu_docs import documentation_html
    from oilwatch.cosim.native_loader import install_loader
    from oilwatch.cosim.packaging import relocated_name, stage_sources

    script = entry.script_path(root)
    if not script.is_file():
        raise InputError(f"{entry.name}: slave script {script} does not exist")
    out_dir.mkdir(parents=True, exist_ok=True)
    fmu_path = out_dir / f"{entry.name}.fmu"
    staged_names = {script.stem} | {relocated_name(entry.prefix, p) for p in entry.packages}
    with tempfile.TemporaryDirectory(prefix=f"oilwatch_{entry.name}_") as tmp:
        staging = Path(tmp)
        staged_script, folders = stage_sources(
            staging, root, script, entry.packages, entry.prefix, entry.data_globs
        )
        saved_path = list(sys.path)
        try:
            built = FmuBuilder.build_FMU(staged_script, dest=fmu_path, project_files=folders, **entry.options)
        finally:
            sys.path[:] = saved_path
            _forget_modules(staged_names)
    built = Path(built)
    with zipfile.ZipFile(built) as archive:
        identifier = archive.read("resources/slavemodule.txt").decode().strip()
        names = archive.namelist()
    if not any(n == f"binaries/linux64/{entry.name}.so" for n in names):
        built.unlink()
        raise InputError(
            f"{entry.name}: the slave class in {script.name} must be named {entry.name} "
            f"(pythonfmu names the model after the class; module {identifier})"
        )
    install_loader(built, entry.name)  # self-sufficient binary: oilwatch/cosim/native_loader.py
    with zipfile.ZipFile(built, "a") as archive:
        archive.writestr("documentation/index.html", documentation_html(built))
    problems = validate_fmu(str(built))
    if problems:
        raise InputError(f"{entry.name}: fmpy validate found problems: " + "; ".join(problems))
    return built


def build_fmus(
    out_dir: Path | str = "build",
    only: list[str] | None = None,
    extra: tuple[FmuEntry, ...] | list[FmuEntry] = (),
    root: Path = REPO_ROOT,
    registry: tuple[FmuEntry, ...] = REGISTRY,
    systems: tuple[SspEntry, ...] = SYSTEMS,
) -> list[Path]:
    """Build the registered FMUs (plus ``extra``), or only those named in ``only``, then every
    SSP system of ``systems`` whose FMUs were all built in this call. Returns the files written."""
    entries = {entry.name: entry for entry in (*registry, *extra)}
    if only:
        unknown = [name for name in only if name not in entries]
        if unknown:
            raise InputError(f"--only: unknown FMU {unknown}; known: {sorted(entries)}")
        selected = [entries[name] for name in only]
    else:
        selected = list(entries.values())
    prefixes = [entry.prefix for entry in selected]
    if len(set(prefixes)) != len(prefixes):
        raise InputError(f"relocation prefixes must be unique per FMU, got {prefixes}")
    missing = [str(e.script_path(root)) for e in selected if not e.script_path(root).is_file()]
    if missing:
        raise InputError(f"slave script(s) missing: {missing}")
    built = {entry.name: build_fmu(entry, Path(out_dir), root) for entry in selected}
    written = list(built.values())
    for system in systems:
        if all(fmu in built for _, fmu, _ in system.components):
            written.append(write_system(system, built, Path(out_dir)))
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="build", help="output folder (default: build)")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="build only these FMUs")
    args = parser.parse_args(argv)
    try:
        for path in build_fmus(args.out, args.only):
            print(f"built {path}")
    except InputError as error:
        print(f"build.py: error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
