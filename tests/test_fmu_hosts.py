"""The FMUs in hosts that are not oilwatch's: a bare virtual environment and libcosim without BLAS settings.

* Each built FMU is copied to a folder outside the clone and run by fmpy in a fresh virtual environment that
  holds only numpy, scipy, numba and fmpy: the code it bundles imports nothing else (no tqdm, no oilwatch),
  and it limits the process's OpenBLAS to one thread itself (the host sets no OPENBLAS_NUM_THREADS).
* The README's libcosimpy example runs without OPENBLAS_NUM_THREADS as fast as oilwatch's fmpy master (a
  ratio measured in the same test, not an absolute time): before the FMUs limited their own threads it was
  many times slower (107 s for 12 s simulated).
"""

from __future__ import annotations

import json
import shutil
import subprocess

import pytest
from fixtures.venvs import clean_env, make_venv, pinned

pytestmark = pytest.mark.slow

BARE_HOST = r"""
import ctypes, json, os, sys
from pathlib import Path
import numpy as np
from fmpy import simulate_fmu

here = Path.cwd()
plant = simulate_fmu(str(here / "RotorBearingPlant.fmu"), stop_time=0.05, step_size=1e-3,
                     output_interval=1e-3, start_values={"noise_um": 0.0},
                     output=["x1_um", "y1_um", "q1_ml_min"])
ekf = simulate_fmu(str(here / "OilFlowEKF.fmu"), stop_time=0.05, step_size=1e-3, output_interval=1e-3,
                   output=["q1_est_ml_min", "q1_std_ml_min"])
threads = {}
for line in Path("/proc/self/maps").read_text().splitlines():
    path = line.split()[-1]
    if "openblas" in Path(path).name.lower():
        library = ctypes.CDLL(path)
        for name in ("scipy_openblas_get_num_threads", "scipy_openblas_get_num_threads64_",
                     "openblas_get_num_threads"):
            if hasattr(library, name):
                threads[Path(path).name] = getattr(library, name)()
print("@@" + json.dumps({
    "y1_um": float(plant["y1_um"][-1]), "q1_ml_min": float(plant["q1_ml_min"][-1]),
    "q1_est_ml_min": float(ekf["q1_est_ml_min"][-1]), "q1_std_ml_min": float(ekf["q1_std_ml_min"][-1]),
    "threads": threads, "tqdm": "tqdm" in sys.modules, "oilwatch": "oilwatch" in sys.modules,
    "cores": os.cpu_count(),
}))
sys.stdout.flush()
os._exit(0)  # pythonfmu 0.7's teardown may corrupt the heap at exit (PythonFMU issue #228)
"""


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
    assert result["q1_est_ml_min"] == pytest.approx(596.3, rel=0.05)
    assert result["q1_std_ml_min"] > 0.0
    assert not result["tqdm"] and not result["oilwatch"]
    assert result["threads"] and set(result["threads"].values()) == {1}, result["threads"]


LIBCOSIM = r"""
import json, os, sys, time
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimObserver import CosimObserver

log_output_level(CosimLogLevel.ERROR)
execution = CosimExecution.from_ssp_file(sys.argv[1], step_size=1_000_000)
observer = CosimObserver.create_last_value()
execution.add_observer(observer)
ekf = execution.slave_index_from_instance_name("ekf")
refs = {v.name.decode(): v.reference for v in execution.slave_variables(ekf)}
execution.simulate_until(WARM_NS)  # initialization (numba kernels) and the first steps
start = time.perf_counter()
execution.simulate_until(STOP_NS)
wall = time.perf_counter() - start
print("@@" + json.dumps({"wall_s": wall, "q1": observer.last_real_values(ekf, [refs["q1_est_ml_min"]])[0]}))
sys.stdout.flush()
os._exit(0)
"""

FMPY = r"""
import json, os, sys, time
from oilwatch.cosim import Master
from oilwatch.cosim.ssp import open_ssp

with open_ssp(sys.argv[1]) as system, Master(system) as master:
    result = master.run(stop_time=STOP_S, step_size=1e-3, order=["plant", "ekf"],
                        record=["ekf.q1_est_ml_min"])
print("@@" + json.dumps({"wall_s": result.wall_s}))  # the step loop only, initialization excluded
sys.stdout.flush()
os._exit(0)
"""
WARM_S, STOP_S = 0.5, 2.5
MAX_RATIO = 3.0
"""libcosim (Jacobi) and the fmpy master (Gauss-Seidel) step the same FMUs: the same cost per step up to the
masters' small overheads. Without the FMUs' own thread limit the ratio was far above this (see the README)."""


def test_libcosim_without_blas_settings_runs_as_fast_as_the_fmpy_master(built_fmus, tmp_path):
    import sys

    ssp = str(built_fmus / "OilStarvation.ssp")
    libcosim = LIBCOSIM.replace("WARM_NS", str(int(WARM_S * 1e9))).replace("STOP_NS", str(int(STOP_S * 1e9)))
    host = clean_env(OILWATCH_FMU_CACHE="0")  # nothing about BLAS threads, as a user's libcosim host
    process = subprocess.run(
        [sys.executable, "-c", libcosim, ssp], cwd=tmp_path, env=host, capture_output=True, text=True,
        timeout=1200,
    )  # fmt: skip
    osp = _result(process)
    fmpy_code = FMPY.replace("STOP_S", str(STOP_S))
    reference = clean_env(OPENBLAS_NUM_THREADS="1", OILWATCH_FMU_CACHE="0")
    process = subprocess.run(
        [sys.executable, "-c", fmpy_code, ssp], cwd=tmp_path, env=reference, capture_output=True, text=True,
        timeout=1200,
    )  # fmt: skip
    fm = _result(process)
    per_second = (osp["wall_s"] / (STOP_S - WARM_S), fm["wall_s"] / STOP_S)  # wall s per simulated s
    ratio = per_second[0] / per_second[1]
    print(f"wall s per simulated s: libcosim {per_second[0]:.3f}, fmpy {per_second[1]:.3f}: {ratio:.2f}")
    assert ratio < MAX_RATIO
