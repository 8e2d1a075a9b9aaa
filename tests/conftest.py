"""Fixtures shared by the test modules, and the fast tier's rule.

Two tiers (README, Development): ``python -m pytest -q -m "not slow"`` is the fast one, ``python -m pytest
-q`` (CI) runs every test. A test is slow when it is marked ``@pytest.mark.slow`` in its module, or when it
needs the real FMUs built (the ``built_fmus`` fixture, directly or through another fixture): building them
and compiling their kernels in a fresh process is what makes a test slow here.
"""

from __future__ import annotations

import pytest
from fixtures.fmu_subprocess import run_python
from fixtures.toy_fmus import toy_fmu_dir


def pytest_collection_modifyitems(config, items):
    for item in items:
        if "built_fmus" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def built_fmus(tmp_path_factory):
    """RotorBearingPlant.fmu, OilFlowEKF.fmu and OilStarvation.ssp, built once per session by build.py in a
    fresh process (the relocated slave modules must not load into the pytest process); their folder."""
    out = tmp_path_factory.mktemp("oilwatch_fmus")
    process = run_python(f"import build; build.build_fmus({str(out)!r})", timeout=400.0)
    assert process.returncode == 0, process.stderr
    return out


@pytest.fixture(scope="session")
def built_fmi3_fmus(built_fmus, tmp_path_factory):
    """The FMI 3.0 twins of the session's FMUs and of OilStarvation.ssp (pythonfmu3), built once per session
    in a fresh process; their folder."""
    out = tmp_path_factory.mktemp("oilwatch_fmi3_fmus")
    ssp = built_fmus / "OilStarvation.ssp"
    code = "from oilwatch.cosim.fmi3_build import build_fmi3_fmus\n"
    code += f"build_fmi3_fmus({str(out)!r}, [{str(ssp)!r}])"
    process = run_python(code, timeout=400.0)
    assert process.returncode == 0, process.stderr
    return out


@pytest.fixture(scope="session")
def toys(tmp_path_factory):
    """The toy FMUs (ToyPlant.fmu, ToyFilter.fmu, ToySystem.ssp of tests/fixtures), built once per session in
    a fresh process (a few seconds: the fast tier uses them); their folder, which tests only read."""
    return toy_fmu_dir(tmp_path_factory)
