"""Every script in benchmarks/ runs to the end with its smallest settings and prints a row.

Each runs as a user would run it (``python benchmarks/NAME.py ...`` from the repository, a fresh process), on
the session's built FMUs where it times one, with ``$OILWATCH_CACHE`` in the session's temporary folder (the
ramp records the benchmarks cache). What the figures are is the benchmarks' business: here only that the
script finishes (exit code 0) and prints at least one row with a number. The helper modules that have no
command of their own (``ekf_fmu_loop``, ``ekf_step_latency``, ``ekf_step_ramps``, ``step_timing``) run
inside ``ekf_step.py``.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest
from fixtures.fmu_subprocess import REPO_ROOT

BENCHMARKS = REPO_ROOT / "benchmarks"
HELPERS = {"ekf_fmu_loop", "ekf_step_latency", "ekf_step_ramps", "step_timing"}
ARGUMENTS = {
    "bearing_solve": ["--mesh", "24", "8", "--repeats", "1", "--gs-repeats", "1"],
    "bearing_table": ["--repeats", "1", "--points", "3"],
    "ekf_fmu_c_host": [
        "--steps",
        "50",
        "--warmup",
        "10",
        "--runs",
        "1",
        "--plant-fmu",
        "{fmus}/RotorBearingPlant.fmu",
        "--ekf-fmu",
        "{fmus}/OilFlowEKF.fmu",
    ],
    "ekf_fmu_step": ["--steps", "50", "--repeats", "1", "--ramp-s", "0.2", "--fmu", "{fmus}/OilFlowEKF.fmu"],
    "ekf_step": ["--steps", "50", "--repeats", "1", "--ramp-s", "0.2", "--fmu", "{fmus}/OilFlowEKF.fmu"],
    "fmu_cold_start": ["--repeats", "1", "--steps", "300", "--baseline", "{fmus}", "--new", "{fmus}"],
    "estimate_record": ["--hours", "0.0005", "--live-s", "0.5", "--workdir", "{tmp}"],
    "host_blas_threads": ["--fmu-dir", "{fmus}", "--warm-s", "0.05", "--stop-s", "0.1"],
    "master_overhead": ["--steps", "50", "--repeats", "1"],
    "plant_fmu": ["--duration-s", "0.05", "--repeats", "1", "--fmu", "{fmus}/RotorBearingPlant.fmu"],
    "plant_ramps": ["--duration-s", "0.05", "--repeats", "1"],
    "ramp_recentring": ["--motion-cache", "{tmp}", "--cases", "speed-ramp", "--duration-s", "0.5"],
    "study_scaling": ["--case", "synthetic", "--cases", "2", "--repeats", "1", "--cpu-s", "0.05"],
    "transient_film": ["--mesh", "40", "12", "--revolutions", "1", "--warmup-steps", "2"],
    "transient_plant_sample": ["--samples", "3"],
}
"""The smallest settings of each benchmark ({fmus}: the session's built FMUs, {tmp}: a fresh folder)."""
THIRD_PARTY_SCRATCH = ("libcosim_", "dask-scratch-space")
"""What libcosim (master_overhead's SSP run) and dask (study_scaling's local cluster) leave in the temporary
folder; everything else a benchmark writes there it must remove."""
NEEDS_FMUS = {name for name, arguments in ARGUMENTS.items() if any("{fmus}" in a for a in arguments)}


def test_every_benchmark_script_is_listed():
    scripts = {path.stem for path in BENCHMARKS.glob("*.py")}
    assert scripts - HELPERS == set(ARGUMENTS)


def _run(name: str, fmus, tmp_path, cache) -> None:
    arguments = [a.format(fmus=fmus, tmp=tmp_path) for a in ARGUMENTS[name]]
    # the system's temporary folder of the benchmark: each must remove what it unpacks or writes there (an
    # FMU unpack is 4-26 MB, and leftovers over many runs filled the disk)
    scratch = tmp_path / "tmpdir"
    scratch.mkdir()
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OILWATCH_CACHE=str(cache), MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO_ROOT), env.get("PYTHONPATH", "")])
    env["TMPDIR"] = str(scratch)
    process = subprocess.run(
        [sys.executable, str(BENCHMARKS / f"{name}.py"), *arguments],
        cwd=REPO_ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=1200,
    )
    assert process.returncode == 0, process.stderr[-3000:]
    assert re.search(r"\d+\.\d", process.stdout), process.stdout[-2000:]
    # libcosim's unpacks and dask's worker space are the libraries' own: contained here, removed with tmp_path
    left = sorted(p.name for p in scratch.iterdir() if not p.name.startswith(THIRD_PARTY_SCRATCH))
    assert not left, f"left in the temporary folder: {left}"


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("benchmark_cache")


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(set(ARGUMENTS) - NEEDS_FMUS))
def test_the_benchmark_runs_with_its_smallest_settings(name, tmp_path, cache):
    _run(name, None, tmp_path, cache)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(NEEDS_FMUS))
def test_the_fmu_benchmark_runs_with_its_smallest_settings(name, built_fmus, tmp_path, cache):
    _run(name, built_fmus, tmp_path, cache)
