"""Staging an FMU's sources (oilwatch/cosim/packaging.py) and the guard of a shared ``oilwatch`` package
(fmu_src/bundle.py): same sources share, other sources are refused with both versions named."""

from __future__ import annotations

import json
import sys
import types
from pathlib import Path

import pytest

import oilwatch
from oilwatch.cosim.fmu_build import FMU_PACKAGES, package_dir
from oilwatch.cosim.packaging import stage_sources
from oilwatch.fmu_src import bundle
from oilwatch.models.validation import InputError


@pytest.fixture(scope="module")
def staged(tmp_path_factory) -> Path:
    staging = tmp_path_factory.mktemp("staging")
    script = package_dir("fmu_src") / "oilwatch_plant_slave.py"
    folders = {package: package_dir(package) for package in FMU_PACKAGES}
    _, root = stage_sources(staging, folders, script, "9.9.9", ("*.toml", "*.json"))
    return root


def test_staging_copies_the_subpackages_unchanged_and_records_their_digest(staged):
    assert staged.name == "oilwatch" and (staged.parent / "oilwatch_plant_slave.py").is_file()
    for package in FMU_PACKAGES:
        for source in (package_dir(package)).rglob("*.py"):
            if "__pycache__" in source.parts or "tests" in source.parts:
                continue
            copy = staged / package / source.relative_to(package_dir(package))
            assert copy.read_bytes() == source.read_bytes(), copy
    stamp = json.loads((staged / bundle.BUNDLE_FILE).read_text())
    assert stamp == {"version": "9.9.9", "digest": bundle.source_digest(Path(oilwatch.__file__).parent)}
    assert "import" not in (staged / "__init__.py").read_text()  # minimal: nothing beyond the subpackages


def test_staging_refuses_another_set_of_subpackages(tmp_path):
    folders = {"models": package_dir("models")}
    with pytest.raises(InputError, match="exactly the subpackages"):
        stage_sources(tmp_path, folders, package_dir("fmu_src") / "oilwatch_plant_slave.py", "1", ())


def _imported(monkeypatch, folder: Path) -> None:
    module = types.ModuleType("oilwatch")
    module.__file__ = str(folder / "__init__.py")
    monkeypatch.setitem(sys.modules, "oilwatch", module)


@pytest.fixture
def search_paths():
    """The imported oilwatch packages' ``__path__`` lists, restored afterwards (admit extends them)."""
    saved = {m: list(m.__path__) for n, m in list(sys.modules.items()) if n.split(".")[0] == "oilwatch"
             and hasattr(m, "__path__")}  # fmt: skip
    yield
    for module, search in saved.items():
        module.__path__[:] = search


def test_an_fmu_shares_an_imported_oilwatch_with_the_same_sources(staged, monkeypatch, search_paths):
    resources = staged.parent
    assert bundle.admit(str(resources)) == ""  # this process's oilwatch: the sources it bundles
    # and a later lazy import may come from the FMU's copy (the first unpack may be deleted by then)
    assert str(staged / "models") in sys.modules["oilwatch.models"].__path__
    _imported(monkeypatch, staged)
    assert bundle.admit(str(resources)) == ""  # its own copy
    monkeypatch.delitem(sys.modules, "oilwatch")
    assert bundle.admit(str(resources)) == ""  # nothing imported yet: the FMU's own copy will be


def test_an_fmu_refuses_an_imported_oilwatch_with_other_sources_naming_both(staged, tmp_path, monkeypatch):
    other = tmp_path / "other" / "oilwatch"
    other.mkdir(parents=True)
    (other / bundle.BUNDLE_FILE).write_text(json.dumps({"version": "0.0.1", "digest": "0123456789abcdef"}))
    _imported(monkeypatch, other)
    message = bundle.admit(str(staged.parent))
    assert "\n" not in message
    assert "oilwatch 9.9.9 (sources " in message and "oilwatch 0.0.1 (sources 0123456789abcdef)" in message
    assert str(other) in message


KERNEL = "from numba import njit\n\n\n@njit(cache=True)\ndef twice(x):\n    return 2.0 * x\n"
CALL = (
    "import importlib.util, sys\n"
    "spec = importlib.util.spec_from_file_location('seeded_kernel', sys.argv[1])\n"
    "module = sys.modules['seeded_kernel'] = importlib.util.module_from_spec(spec)\n"
    "spec.loader.exec_module(module)\n"
    "print(module.twice(2.0))\n"
)
"""Load the kernel's file as one module name in every folder (an FMU's bundled package is always
``oilwatch``) and call it."""


def _call_kernel(root: Path) -> list[str]:
    """numba's cache log of calling the kernel ``root / "oilwatch" / "kernel.py"`` in a fresh process."""
    import os
    import subprocess

    env = {**os.environ, "NUMBA_DEBUG_CACHE": "1"}
    env.pop("NUMBA_CACHE_DIR", None)
    process = subprocess.run(
        [sys.executable, "-c", CALL, str(root / "oilwatch" / "kernel.py")],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )
    return [line for line in process.stdout.splitlines() if line.startswith("[cache]")]


def test_a_seed_fmus_kernels_are_loaded_by_the_warm_up_of_another_unpack_of_the_same_source(tmp_path):
    """The FMI 3.0 build's warm-up loads what its FMI 2.0 twin compiled (packaging._seed_kernels): numba
    keys a kernel by its source's content, so its files work in another folder; only numba's files are
    copied."""
    import zipfile

    from oilwatch.cosim.packaging import _seed_kernels

    twin = tmp_path / "twin" / "resources"
    (twin / "oilwatch").mkdir(parents=True)
    (twin / "oilwatch" / "kernel.py").write_text(KERNEL)
    assert any("saved" in line for line in _call_kernel(twin))  # the twin's warm-up compiled it
    seed = tmp_path / "twin.fmu"
    with zipfile.ZipFile(seed, "w") as archive:
        for path in (twin / "oilwatch").rglob("*"):
            archive.write(path, path.relative_to(twin.parent).as_posix())
    unpacked = tmp_path / "fmi3"
    (unpacked / "resources" / "oilwatch").mkdir(parents=True)
    (unpacked / "resources" / "oilwatch" / "kernel.py").write_text(KERNEL)
    _seed_kernels(unpacked, seed)
    copied = sorted(p.suffix for p in (unpacked / "resources" / "oilwatch" / "__pycache__").iterdir())
    assert copied and set(copied) <= {".nbi", ".nbc"}
    log = _call_kernel(unpacked / "resources")
    assert any("data loaded" in line for line in log) and not any("saved" in line for line in log), log
