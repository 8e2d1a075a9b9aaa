"""build.py: the command line, its errors, and the SSP system it writes after the FMUs."""

from __future__ import annotations

import subprocess
import sys
import zipfile

from fixtures.fmu_subprocess import REPO_ROOT, run_python


def test_build_writes_the_fmus_and_the_ssp_system(toys):
    assert (toys / "ToyPlant.fmu").is_file() and (toys / "ToyFilter.fmu").is_file()
    with zipfile.ZipFile(toys / "ToySystem.ssp") as archive:
        ssd = archive.read("SystemStructure.ssd").decode()
        assert "resources/ToyPlant.fmu" in archive.namelist()
    assert 'startElement="plant" startConnector="y_um"' in ssd
    assert 'ssv:Real value="0.05"' in ssd


def test_unknown_fmu_name_is_a_one_line_error_with_exit_code_2(tmp_path):
    command = [sys.executable, "build.py", "--out", str(tmp_path), "--only", "Nope"]
    process = subprocess.run(command, cwd=REPO_ROOT, capture_output=True, text=True, timeout=120)
    assert process.returncode == 2
    assert "unknown FMU ['Nope']" in process.stderr
    assert "Traceback" not in process.stderr


def test_missing_slave_script_is_reported_before_anything_is_built(tmp_path):
    process = run_python(
        "from oilwatch.cosim.fmu_build import FmuEntry, build_fmus\n"
        "from oilwatch.models.validation import InputError\n"
        "entry = FmuEntry('Ghost', 'fmu_src/ghost_slave.py', ('fmu_src',), 'ghost')\n"
        "try:\n"
        f"    build_fmus({str(tmp_path)!r}, extra=[entry], only=['Ghost'])\n"
        "except InputError as error:\n"
        "    print(error)\n"
    )
    assert "slave script(s) missing" in process.stdout and "ghost_slave.py" in process.stdout
    assert not any(tmp_path.iterdir())
