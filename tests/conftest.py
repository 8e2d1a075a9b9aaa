"""Fixtures shared by the test modules, and the fast tier's rule.

Two tiers (README, Development): ``python -m pytest -q -m "not slow"`` is the fast one, ``python -m pytest
-q`` (CI) runs every test. A test is slow when it is marked ``@pytest.mark.slow`` in its module, or when it
needs the real FMUs built (the ``built_fmus`` fixture, directly or through another fixture): building them
and compiling their kernels in a fresh process is what makes a test slow here.
"""

from __future__ import annotations

import pytest
from fixtures.fmu_subprocess import run_python


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
