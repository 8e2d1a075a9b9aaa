"""The FMUs in hosts that are not oilwatch's: a bare virtual environment and libcosim without BLAS settings.

* Each built FMU is copied to a folder outside the clone and run by fmpy in a fresh virtual environment that
  holds only numpy, scipy, numba and fmpy: the code it bundles imports nothing else (no tqdm, no oilwatch),
  and it limits the process's OpenBLAS to one thread itself (the host sets no OPENBLAS_NUM_THREADS).
* The README's libcosimpy example, without OPENBLAS_NUM_THREADS, runs every OpenBLAS one thread (its time
  with and without the setting is a benchmark's figure: ``benchmarks/host_blas_threads.py``).
* libcosim, which unpacks into fresh folders, compiles none of the FMUs' numba kernels: the build shipped
  them all, the estimator's in the plant FMU too.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from fixtures.fmu_subprocess import assert_shipped_kernels_loaded_and_none_compiled
from fixtures.host_timing import LIBCOSIM, OPENBLAS_THREADS, time_host
from fixtures.venvs import clean_env, make_venv, pinned

pytestmark = pytest.mark.slow

BARE_HOST = (
    OPENBLAS_THREADS
    + r"""
import json, os, sys
from pathlib import Path
import numpy as np
from fmpy import simulate_fmu

here = Path.cwd()
plant = simulate_fmu(str(here / "RotorBearingPlant.fmu"), stop_time=0.05, step_size=1e-3,
                     output_interval=1e-3, start_values={"noise_um": 0.0},
                     output=["x1_um", "y1_um", "q1_ml_min"])
ekf = simulate_fmu(str(here / "OilFlowEKF.fmu"), stop_time=0.05, step_size=1e-3, output_interval=1e-3,
                   output=["q1_est_ml_min", "q1_std_ml_min"])
threads = openblas_threads()
print("@@" + json.dumps({
    "y1_um": float(plant["y1_um"][-1]), "q1_ml_min": float(plant["q1_ml_min"][-1]),
    "q1_est_ml_min": float(ekf["q1_est_ml_min"][-1]), "q1_std_ml_min": float(ekf["q1_std_ml_min"][-1]),
    "threads": threads, "tqdm": "tqdm" in sys.modules,
    "oilwatch": getattr(sys.modules.get("oilwatch"), "__file__", None),
    "cores": os.cpu_count(),
}))
sys.stdout.flush()
os._exit(0)  # pythonfmu 0.7's teardown may corrupt the heap at exit (PythonFMU issue #228)
"""
)


def _result(process: subprocess.CompletedProcess) -> dict:
    assert process.returncode == 0, f"{process.stdout[-2000:]}\n{process.stderr[-4000:]}"
    line = [text for text in process.stdout.splitlines() if text.startswith("@@")][-1]
    return json.loads(line[2:])


def test_each_fmu_runs_in_a_bare_venv_outside_the_clone(built_fmus, tmp_path):
    python = make_venv(tmp_path / "venv", pinned("numpy", "scipy", "numba", "fmpy"))
    host = tmp_path / "host"
    host.mkdir()
    for name in ("RotorBearingPlant.fmu", "OilFlowEKF.fmu"):
        shutil.copy2(built_fmus / name, host / name)
    env = clean_env(OILWATCH_FMU_CACHE="0")
    process = subprocess.run(
        [str(python), "-c", BARE_HOST], cwd=host, env=env, capture_output=True, text=True, timeout=900
    )
    result = _result(process)
    assert result["q1_ml_min"] == pytest.approx(596.3)  # the bundled machine's nominal (reference value)
    assert -60.0 < result["y1_um"] < 0.0  # the journal sits below the bearing centre
    assert 250.0 < result["q1_est_ml_min"] < 850.0  # inside the bundled table (its inputs are left at 0 here)
    assert result["q1_std_ml_min"] > 0.0
    assert not result["tqdm"]
    # the FMUs bundle oilwatch unrenamed: the one imported is an FMU's own copy, from its resources folder
    assert Path(result["oilwatch"]).parent.parent.name == "resources", result["oilwatch"]
    assert result["threads"] and set(result["threads"].values()) == {1}, result["threads"]


WARM_S, STOP_S = 0.1, 0.3


def test_libcosim_without_blas_settings_runs_every_openblas_one_thread(built_fmus, tmp_path):
    """In a libcosim host that sets nothing about BLAS, every OpenBLAS the FMUs load runs one thread (the
    FMUs limit their own threads). What that is worth in time, the same host with and without
    OPENBLAS_NUM_THREADS=1 and against oilwatch's fmpy master, is ``benchmarks/host_blas_threads.py``'s."""
    ssp = built_fmus / "OilStarvation.ssp"
    host = clean_env(OILWATCH_FMU_CACHE="0")  # nothing about BLAS threads, as a user's libcosim host
    bare = time_host(LIBCOSIM, ssp, WARM_S, STOP_S, host, tmp_path)
    assert bare["threads"] and set(bare["threads"].values()) == {1}, bare["threads"]


LIBCOSIM_START = r"""
import os, sys
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

log_output_level(CosimLogLevel.ERROR)
execution = CosimExecution.from_ssp_file(sys.argv[1], step_size=1_000_000)
execution.simulate_until(50_000_000)
print("@@done")
sys.stdout.flush()
os._exit(0)
"""


def test_a_libcosim_host_loads_every_kernel_the_build_shipped_and_compiles_none(built_fmus, tmp_path):
    """libcosim unpacks the SSP's FMUs into a fresh folder and loads the plant first, so the estimator's code
    comes from the plant's folder (one oilwatch per process), on the SSP's paper preset. numba's cache log
    says what each kernel did: "data loaded" from the shipped files, "data saved" after compiling it here."""
    env = clean_env(OILWATCH_FMU_CACHE="0", NUMBA_DEBUG_CACHE="1")
    process = subprocess.run(
        [sys.executable, "-c", LIBCOSIM_START, str(built_fmus / "OilStarvation.ssp")],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert_shipped_kernels_loaded_and_none_compiled(process)
