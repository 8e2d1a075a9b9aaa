"""Where an FMU is unpacked: a persistent folder per FMU content, so that compiled code survives runs.

A pythonfmu FMU runs its Python sources from the folder it is unpacked into. The estimator FMU compiles
numba kernels with ``cache=True`` on first use (5-15 s); numba keys its on-disk cache by the source file's
path and modification time, so a fresh temporary folder per run recompiles every time. Unpacking each FMU
once per instance name into ``<cache>/fmus/oilwatch_<instance>_<sha256 of the .fmu>/`` keeps both stable:
the second and later runs load the compiled kernels (measured: initialization of OilFlowEKF 10-15 s ->
0.3 s, see the README). One folder per instance name, as with temporary folders, so that two instances
never share files.

``<cache>`` is ``$OILWATCH_CACHE`` if set, else ``~/.cache/oilwatch``. ``OILWATCH_FMU_CACHE=0`` switches
the persistent folders off (a temporary folder per instance, deleted on close). A folder is created
atomically (unpacked under a temporary name, then renamed), so concurrent processes never see half an
FMU. Every FMU build has a new GUID, hence a new hash: each use touches its folder and only the
:data:`KEEP_FOLDERS` most recently used are kept. The folders can be deleted at any time when no run is
using them.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from pathlib import Path

from fmpy import extract

from models.cache import user_cache_dir

_HASH_CHUNK = 1 << 20
KEEP_FOLDERS = 24
"""Unpacked FMUs kept in ``<cache>/fmus`` (least recently used ones beyond this are deleted)."""


cache_root = user_cache_dir
"""The oilwatch cache folder: ``$OILWATCH_CACHE`` or ``~/.cache/oilwatch`` (shared with the tables)."""


def persistent_extraction_enabled() -> bool:
    """False when ``OILWATCH_FMU_CACHE`` is ``0``, ``false``, ``no`` or ``off``."""
    return os.environ.get("OILWATCH_FMU_CACHE", "1").strip().lower() not in ("0", "false", "no", "off")


def content_hash(path: Path) -> str:
    """SHA-256 (hex) of the file at ``path``."""
    digest = hashlib.sha256()
    with Path(path).open("rb") as stream:
        for chunk in iter(lambda: stream.read(_HASH_CHUNK), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _complete(folder: Path) -> bool:
    return (folder / "modelDescription.xml").is_file() and (folder / "binaries").is_dir()


def extract_fmu(path: Path, prefix: str) -> tuple[Path, bool]:
    """Unpack the FMU at ``path`` for the instance called ``prefix``; return ``(folder, persistent)``.

    persistent True: the folder ``<cache>/fmus/oilwatch_<prefix>_<sha256>/``, reused by every later
    instance of that name and content (never deleted by the caller); False: a new temporary folder
    ``oilwatch_<prefix>_*`` the caller must delete (cache switched off or not writable).
    """
    if persistent_extraction_enabled():
        try:
            return _persistent_folder(Path(path), prefix), True
        except OSError:
            pass  # a read-only home or full disk: fall back to a private temporary folder
    folder = Path(tempfile.mkdtemp(prefix=f"oilwatch_{prefix}_"))
    try:
        extract(str(path), unzipdir=str(folder))
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    return folder, False


def _persistent_folder(path: Path, prefix: str) -> Path:
    parent = cache_root() / "fmus"
    folder = parent / f"oilwatch_{prefix}_{content_hash(path)}"
    if _complete(folder):
        os.utime(folder)
        return folder
    parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".partial-", dir=parent))
    try:
        extract(str(path), unzipdir=str(staging))
        if folder.exists() and not _complete(folder):
            shutil.rmtree(folder, ignore_errors=True)
        try:
            staging.rename(folder)
        except OSError:
            if not _complete(folder):  # not another process that won the race: a real failure
                raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    prune(parent, KEEP_FOLDERS)
    return folder


def prune(parent: Path, keep: int) -> None:
    """Delete all but the ``keep`` most recently modified folders in ``parent`` (unfinished ones, named
    ``.partial-*``, are left to their writers)."""
    folders = [p for p in parent.iterdir() if p.is_dir() and not p.name.startswith(".")]
    folders.sort(key=lambda p: p.stat().st_mtime, reverse=True)
    for stale in folders[keep:]:
        shutil.rmtree(stale, ignore_errors=True)
