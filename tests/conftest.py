"""Fixtures shared by the test modules, and the fast tier's rule.

Two tiers (README, Development): ``python -m pytest -q -m "not slow"`` is the fast one, ``python -m pytest
-q`` (CI) runs every test. A test is slow when it is marked ``@pytest.mark.slow`` in its module, or when it
needs the real FMUs built (the ``built_fmus`` fixture, directly or through another fixture): building them
and compiling their kernels in a fresh process is what makes a test slow here.

On two workers (``python -m pytest -q -n 2 --dist loadgroup``, the README's and CI's command) the session's
built FMUs are built once and shared by the workers: the first worker to need them builds them under a file
lock in the session's common temporary folder, the others wait and reuse them (the same files, so the same
unpacked folders and numba caches in ``$OILWATCH_CACHE``). ``fixtures/xdist_units.py`` splits the suite.
"""

from __future__ import annotations

import contextlib
import os

import pytest
from fixtures.fmu_subprocess import run_python
from fixtures.toy_fmus import toy_fmu_dir
from fixtures.xdist_units import group_and_order, session_root


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist's, which reads the xdist_group markers added here
def pytest_collection_modifyitems(config, items):
    for item in items:
        if "built_fmus" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.slow)
    if config.getoption("loadgroup", False):  # a worker of --dist loadgroup (its own "dist" is "no")
        group_and_order(items)


def pytest_configure(config):
    if config.getoption("dist", "no") == "loadgroup":
        # The units go to the workers in collection order (longest first, see group_and_order), not
        # reordered by their number of tests.
        config.option.loadscopereorder = False


@contextlib.contextmanager
def _session_folder(tmp_path_factory, name: str):
    """A folder for a session-wide build: yields (folder, True) to the one process that must build into it,
    (folder, False) when it is already built. Without xdist a fresh temporary folder; with it a folder of
    the temporary root all workers of the session share, built under an exclusive lock (fcntl)."""
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        yield tmp_path_factory.mktemp(name), True
        return
    import fcntl

    root = session_root(tmp_path_factory)
    folder, done = root / name, root / f"{name}.done"
    with open(root / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if done.exists():
            yield folder, False
            return
        folder.mkdir(exist_ok=True)
        yield folder, True
        done.touch()  # only after a build that raised nothing


@pytest.fixture(scope="session")
def built_fmus(tmp_path_factory):
    """RotorBearingPlant.fmu, OilFlowEKF.fmu and OilStarvation.ssp, built once per session by build.py in a
    fresh process (the slave modules must not load into the pytest process); their folder."""
    with _session_folder(tmp_path_factory, "oilwatch_fmus") as (out, build):
        if build:
            code = f"from oilwatch.cosim.fmu_build import build_fmus; build_fmus({str(out)!r})"
            process = run_python(code, timeout=1800.0)
            assert process.returncode == 0, process.stderr
    return out


@pytest.fixture(scope="session")
def built_fmi3_fmus(built_fmus, tmp_path_factory):
    """The FMI 3.0 twins of the session's FMUs and of OilStarvation.ssp (pythonfmu3), built once per session
    in a fresh process; their folder."""
    with _session_folder(tmp_path_factory, "oilwatch_fmi3_fmus") as (out, build):
        if build:
            ssp = built_fmus / "OilStarvation.ssp"
            code = "from oilwatch.cosim.fmi3_build import build_fmi3_fmus\n"
            code += f"build_fmi3_fmus({str(out)!r}, [{str(ssp)!r}])"
            process = run_python(code, timeout=1800.0)
            assert process.returncode == 0, process.stderr
    return out


@pytest.fixture(scope="session")
def toys(tmp_path_factory):
    """The toy FMUs (ToyPlant.fmu, ToyFilter.fmu, ToySystem.ssp of tests/fixtures), built once per session in
    a fresh process (a few seconds: the fast tier uses them); their folder, which tests only read."""
    return toy_fmu_dir(tmp_path_factory)


@pytest.fixture(scope="session")
def probe_nuisance_cosims(built_fmus, tmp_path_factory):
    """The co-simulations of tests/test_fmu_keyphasor.py and tests/test_fmu_runout.py in ONE fresh process
    (their tests share an ``xdist_group``, so one worker runs it): the second run's FMU instances reuse the
    first's imported modules and compiled kernels. ``{"keyphasor": ..., "runout": ...}``."""
    import test_fmu_keyphasor
    import test_fmu_runout
    from fixtures.fmu_subprocess import run_json
    from test_ekf_fmu import FMPY_PRELUDE

    folder = tmp_path_factory.mktemp("runout_machine")
    code = FMPY_PRELUDE + "import numpy as np\n" + test_fmu_keyphasor.CODE + test_fmu_runout.CODE
    code += test_fmu_keyphasor.call(built_fmus) + test_fmu_runout.call(built_fmus, folder)
    return run_json(code + 'result = {"keyphasor": keyphasor, "runout": runout}\n', timeout=900)
