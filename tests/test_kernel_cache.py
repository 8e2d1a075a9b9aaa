"""numba's cache of the installed oilwatch follows its sources (oilwatch.kernel_cache): a kernel compiled with
another file's kernel inlined is dropped when that file changes, which numba alone does not do."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import oilwatch
from oilwatch.kernel_cache import STAMP, refresh, sources_digest

CALLER = """
from numba import njit
from pkg.callee import gain

@njit(cache=True)
def scaled(x):
    return gain(x)
"""
CALLEE = """
from numba import njit

@njit(cache=True)
def gain(x):
    return {factor} * x
"""
RUN = "import sys; sys.path.insert(0, sys.argv[1]); {guard}from pkg.caller import scaled; print(scaled(1.0))"


def _package(root: Path, factor: float) -> Path:
    package = root / "pkg"
    package.mkdir(parents=True, exist_ok=True)
    (package / "__init__.py").write_text("")
    (package / "caller.py").write_text(CALLER)
    (package / "callee.py").write_text(textwrap.dedent(CALLEE.format(factor=factor)))
    return package


def _scaled(root: Path, guard: bool) -> float:
    code = RUN.format(
        guard="from pathlib import Path; from oilwatch.kernel_cache import refresh; "
        "refresh(Path(sys.argv[1]) / 'pkg'); "
        if guard
        else ""
    )
    process = subprocess.run(
        [sys.executable, "-c", code, str(root)], capture_output=True, text=True, timeout=300
    )
    assert process.returncode == 0, process.stderr[-2000:]
    return float(process.stdout.split()[-1])


@pytest.mark.slow  # three numba compilations in fresh processes
def test_a_changed_callee_reaches_its_cached_caller_only_through_the_refresh(tmp_path):
    unguarded, guarded = tmp_path / "unguarded", tmp_path / "guarded"
    for root in (unguarded, guarded):
        _package(root, 2.0)
        assert _scaled(root, guard=root is guarded) == 2.0
        _package(root, 3.0)  # the callee's file changes, the caller's does not
    assert _scaled(unguarded, guard=False) == 2.0  # numba alone: the caller's cache holds the old callee
    assert _scaled(guarded, guard=True) == 3.0


def test_the_cache_files_go_only_when_a_source_that_imports_numba_changes(tmp_path):
    package = _package(tmp_path, 2.0)
    (package / "plain.py").write_text("VALUE = 1\n")
    cache = package / "__pycache__"
    cache.mkdir()
    index = cache / "caller.scaled-5.py311.nbi"
    index.write_bytes(b"index")
    assert refresh(package) is True and not index.exists()  # no digest recorded yet
    assert (package / STAMP).read_text().strip() == sources_digest(package)
    index.write_bytes(b"index")
    (package / "plain.py").write_text("VALUE = 2\n")  # no numba in it
    assert refresh(package) is False and index.exists()
    _package(tmp_path, 3.0)
    assert refresh(package) is True and not index.exists()


def test_importing_oilwatch_records_the_digest_of_its_kernel_sources():
    root = Path(oilwatch.__file__).parent
    assert (root / STAMP).read_text().strip() == sources_digest(root)


def test_the_build_and_the_installed_oilwatch_share_kernels_only_between_the_same_sources(tmp_path):
    from oilwatch.cosim.packaging import BUNDLE_FILE, copy_kernels, installed_twin
    from oilwatch.fmu_src.bundle import source_digest

    source, target = tmp_path / "installed", tmp_path / "bundled"
    cache = source / "models" / "bearing" / "__pycache__"
    cache.mkdir(parents=True)
    for name in ("film.solve-10.py311.nbi", "film.solve-10.py311.1.nbc", "film.solve-10.py311.2.nbc",
                 "film.other-30.py311.nbi", "film.other-30.py311.1.nbc", "film.cpython-311.pyc"):  # fmt: skip
        (cache / name).write_bytes(name.encode())
    kept = target / "models" / "bearing" / "__pycache__"
    kept.mkdir(parents=True)
    (kept / "film.other-30.py311.nbi").write_bytes(b"its own")  # an index of its own is never replaced
    assert copy_kernels(source, target) == 1
    assert sorted(p.name for p in kept.iterdir()) == [
        "film.other-30.py311.nbi", "film.solve-10.py311.1.nbc", "film.solve-10.py311.2.nbc",
        "film.solve-10.py311.nbi",
    ]  # fmt: skip
    assert (kept / "film.other-30.py311.nbi").read_bytes() == b"its own"

    installed = Path(oilwatch.__file__).parent
    (target / BUNDLE_FILE).write_text(json.dumps({"digest": source_digest(installed)}))
    assert installed_twin(target) == installed
    (target / BUNDLE_FILE).write_text(json.dumps({"digest": "0" * 16}))
    assert installed_twin(target) is None
