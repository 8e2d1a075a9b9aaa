"""Conformance of every FMU the build makes: ``fmpy validate`` and fmu-manipulation-toolbox's checker.

The FMI 2.0 FMUs and their FMI 3.0 twins. Both tools read the archive (model description against the FMI
schema, then semantic checks); neither loads the binary, so they run in the pytest process. The session builds
(``built_fmus``, ``built_fmi3_fmus``) are checked, so an FMU added to a registry is covered without editing
this file.
"""

from __future__ import annotations

import subprocess
import sys

import pytest
from fmpy.validation import validate_fmu


@pytest.fixture(scope="module")
def fmu_files(built_fmus, built_fmi3_fmus):
    """Every FMU of the session builds: FMI 2.0 and their FMI 3.0 twins."""
    files = sorted(built_fmus.rglob("*.fmu")) + sorted(built_fmi3_fmus.rglob("*.fmu"))
    assert [f.name for f in files].count("RotorBearingPlant.fmu") == 2
    assert [f.name for f in files].count("OilFlowEKF.fmu") == 2
    return files


def test_fmpy_validate_reports_no_problem_for_every_built_fmu(fmu_files):
    assert {str(f): validate_fmu(str(f)) for f in fmu_files} == {str(f): [] for f in fmu_files}


def test_fmutool_check_passes_every_built_fmu(fmu_files):
    for fmu in fmu_files:
        process = subprocess.run(
            [
                sys.executable,
                "-c",
                "import sys; from fmu_manipulation_toolbox.cli.fmutool import fmutool; sys.exit(fmutool())",
                "-input",
                str(fmu),
                "-check",
            ],
            capture_output=True,
            text=True,
            timeout=120,
        )
        output = process.stdout + process.stderr
        assert process.returncode == 0, output
        assert "seems to be compliant with FMI-" in output, output
        assert "No semantic error against the FMI-" in output, output
        assert "ERROR" not in output, output
