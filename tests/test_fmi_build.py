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


def _shipped(fmu) -> dict[str, int]:
    """{member: CRC} of what ship_compiled added (the compiled files) to a toy FMU."""
    with zipfile.ZipFile(fmu) as archive:
        return {i.filename: i.CRC for i in archive.infolist() if "__pycache__" in i.filename}


def test_a_rebuild_of_the_same_content_reuses_the_compiled_files(toys, tmp_path, monkeypatch):
    from oilwatch.cosim.packaging import compiled_key, ship_compiled

    monkeypatch.setenv("OILWATCH_CACHE", str(tmp_path / "cache"))
    copies = []
    for name in ("first", "second", "uncached"):
        copies.append(tmp_path / f"{name}.fmu")
        copies[-1].write_bytes((toys / "ToyPlant.fmu").read_bytes())
    assert ship_compiled(copies[0], "ToyPlant") is False  # warmed up here, and kept
    assert ship_compiled(copies[1], "ToyPlant") is True
    first = _shipped(copies[0])
    assert first and _shipped(copies[1]) == first
    monkeypatch.setenv("OILWATCH_FMU_CACHE", "0")
    assert ship_compiled(copies[2], "ToyPlant") is False
    assert set(_shipped(copies[2])) == set(first)  # the files a warm-up writes (bytecode names its folder)
    folders = []
    for name in ("a", "b"):
        folders.append(tmp_path / name)
        zipfile.ZipFile(toys / "ToyPlant.fmu").extractall(folders[-1])
    assert compiled_key(folders[0]) == compiled_key(folders[1])
    source = next((folders[1] / "resources" / "oilwatch").rglob("*.py"))
    source.write_text(source.read_text() + "\n# changed\n")
    assert compiled_key(folders[0]) != compiled_key(folders[1])
