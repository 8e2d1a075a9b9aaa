"""The FMUs on a machine that did not build them, and the platforms they claim (slow).

Relocation: a second virtual environment, made by another Python minor version than the one that built the
FMUs (pyenv's or the system's; skipped with the reason when this machine has none with a shared libpython):
Python 3.10, the oldest the FMUs claim, when this machine has it (its standard library has no TOML reader:
the FMUs read their machine files' parsed twins, ``oilwatch.models.machine.PARSED_TWIN_SUFFIX``), with
numpy, scipy, numba and fmpy at the newest versions that support it; else the nearest newer minor with this
environment's versions (not pythonfmu: the FMUs bundle its Python part). One setting,
``OILWATCH_PYTHON_ENV``, must be enough: the C host (tests/c_host/fmi2_host.c) runs both FMUs coupled under
``env -i`` (no other variable at all), and fmpy runs the plant FMU alone in that environment's Python (a
host that has Python: no setting; the estimator FMU is loaded the same way, and runs there in the C host).
In another Python the FMUs' shipped kernels do not apply and each run compiles its own.

Platforms: each FMU (FMI 2.0 and 3.0) holds binaries for one platform only, and the FMI 2.0 one is
oilwatch's loader (its own entry points), the binary the C host and fmpy tests load and step.
"""

from __future__ import annotations

import ctypes
import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from fixtures.venvs import make_venv, pinned
from test_c_host import CONNECTED, HostFmu

pytestmark = pytest.mark.slow

PYENV_ROOT = Path(os.environ.get("PYENV_ROOT", Path.home() / ".pyenv"))
CANDIDATES = [
    *sorted((PYENV_ROOT / "versions").glob("3.1[0-9]*/bin/python3")),
    *(Path(p) for p in (shutil.which(f"python3.{minor}") for minor in range(10, 15)) if p),
]
"""Interpreters of other minor versions: pyenv's, and any python3.N on the PATH."""
PACKAGES = ("numpy", "scipy", "numba", "fmpy")
OLDEST = (3, 10)
"""The oldest Python the FMUs run in (docs/fmus.md, runtime requirements)."""
STOP, STEP = 0.2, 1e-3


def _minor(python: Path) -> tuple[int, int] | None:
    """(major, minor) of ``python`` when it has a shared libpython, else None."""
    code = (
        "import sys, sysconfig, pathlib; d = sysconfig.get_config_var('LIBDIR') or ''; "
        "n = sysconfig.get_config_var('INSTSONAME') or ''; "
        "print(sys.version_info[0], sys.version_info[1], int('.so' in n and (pathlib.Path(d) / n).is_file()))"
    )
    try:
        out = subprocess.run(
            [str(python), "-c", code], capture_output=True, text=True, timeout=30
        ).stdout.split()
    except OSError:
        return None
    return (int(out[0]), int(out[1])) if len(out) == 3 and out[2] == "1" else None


def _other_pythons() -> dict[tuple[int, int], Path]:
    """{(major, minor): interpreter} of the Pythons 3.10 or newer with a shared libpython here, other than
    this one's minor version."""
    own = sys.version_info[:2]
    found = {}
    for python in CANDIDATES:
        version = _minor(python) if python.is_file() else None
        if version and version != own and version >= OLDEST:
            found.setdefault(version, python)
    return found


def _venv(tmp_path_factory, python: Path, requirements: list[str]) -> Path:
    folder = tmp_path_factory.mktemp("other_python") / "venv"
    make_venv(folder, requirements, base=python)
    return folder


@pytest.fixture(scope="module")
def other_venv(tmp_path_factory) -> Path:
    """A virtual environment of another Python minor version with the FMUs' packages (module docstring)."""
    own = sys.version_info[:2]
    found = _other_pythons()
    if not found:
        pytest.skip(f"no Python 3.10+ other than {own[0]}.{own[1]} with a shared libpython on this machine")
    if OLDEST in found:  # pip's choice of packages: today's no longer support it
        return _venv(tmp_path_factory, found[OLDEST], list(PACKAGES))
    # the nearest newer minor first: the packages' current versions may no longer support older ones
    version = min(found, key=lambda v: (v < own, abs(v[1] - own[1])))
    return _venv(tmp_path_factory, found[version], pinned(*PACKAGES))


def test_the_c_host_runs_both_fmus_with_only_oilwatch_python_env_set(built_fmus, other_venv, tmp_path):
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    host = tmp_path / "fmi2_host"
    source = Path(__file__).parent / "c_host" / "fmi2_host.c"
    subprocess.run([compiler, "-O2", "-o", str(host), str(source), "-ldl"], check=True)
    plant = HostFmu(built_fmus / "RotorBearingPlant.fmu", tmp_path / "plant", "plant")
    ekf = HostFmu(built_fmus / "OilFlowEKF.fmu", tmp_path / "ekf", "ekf")
    spec = plant.spec({}) + ekf.spec({})
    spec += [f"connect plant {plant.vr(n)} ekf {ekf.vr(n)}" for n in CONNECTED]
    spec += [f"output ekf {ekf.vr('q1_est_ml_min')} q1_est_ml_min", f"run {STOP!r} {STEP!r}"]
    (tmp_path / "spec.txt").write_text("\n".join(spec) + "\n")
    process = subprocess.run(
        [
            "env",
            "-i",
            f"OILWATCH_PYTHON_ENV={other_venv}",
            str(host),
            str(tmp_path / "spec.txt"),
            str(tmp_path / "out.csv"),
        ],
        capture_output=True,
        text=True,
        timeout=1800,
    )
    assert process.returncode == 0, process.stderr[-3000:]
    assert "no Python in this process before loading the FMUs" in process.stderr
    assert "freed 2 instances, unloaded 2 libraries" in process.stderr
    rows = (tmp_path / "out.csv").read_text().splitlines()
    assert len(rows) == 1 + round(STOP / STEP)
    assert all(float(row.split(",")[-1]) > 0.0 for row in rows[1:])


FMPY_RUN = """
import json, sys
from fmpy import simulate_fmu
result = simulate_fmu(sys.argv[1], stop_time={stop!r}, output_interval={step!r})
print(json.dumps({{"rows": len(result), "version": list(sys.version_info[:2])}}))
"""


def test_fmpy_runs_the_plant_fmu_in_another_pythons_environment(built_fmus, other_venv, tmp_path):
    env = {"PATH": os.environ.get("PATH", ""), "HOME": str(tmp_path), "OPENBLAS_NUM_THREADS": "1"}
    process = subprocess.run(
        [
            str(other_venv / "bin" / "python"),
            "-c",
            FMPY_RUN.format(stop=STOP, step=STEP),
            str(built_fmus / "RotorBearingPlant.fmu"),
        ],
        capture_output=True,
        text=True,
        timeout=1800,
        env=env,
        cwd=tmp_path,
    )
    assert process.returncode == 0, process.stderr[-3000:]
    outcome = json.loads(process.stdout.strip().splitlines()[-1])
    assert outcome["version"] != list(sys.version_info[:2])
    assert outcome["rows"] >= round(STOP / STEP)


def test_each_fmu_claims_only_the_platform_whose_binary_is_oilwatchs_and_tested(
    built_fmus, built_fmi3_fmus, tmp_path
):
    for folder, platform, entry in ((built_fmus, "linux64", "oilwatch_loader_bind_buffers"),
                                    (built_fmi3_fmus, "x86_64-linux", None)):  # fmt: skip
        for fmu in sorted(folder.glob("*.fmu")):
            with zipfile.ZipFile(fmu) as archive:
                binaries = [
                    n for n in archive.namelist() if n.startswith("binaries/") and not n.endswith("/")
                ]
                identifier = fmu.stem
                assert {n.split("/")[1] for n in binaries} == {platform}, (fmu, binaries)
                if entry:
                    own = tmp_path / f"{identifier}.so"
                    own.write_bytes(archive.read(f"binaries/{platform}/{identifier}.so"))
                    assert hasattr(ctypes.CDLL(str(own)), entry), (
                        fmu
                    )  # the loader, not pythonfmu's stock binary
