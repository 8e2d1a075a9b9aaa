"""Where an FMU is unpacked: a persistent folder per FMU content, so that compiled code survives runs.

A pythonfmu FMU runs its Python sources from the folder it is unpacked into. The build ships the numba
kernels compiled for its own CPU, Python and numba (:mod:`oilwatch.cosim.packaging`); on any other machine
the kernels compile on first use, with ``cache=True``, into ``__pycache__`` beside the sources, so a fresh
temporary folder per run would compile them every time. Unpacking each FMU once per instance name into
``<cache>/fmus/oilwatch_<instance>_<sha256 of the .fmu>/`` keeps them: the second and later runs load what
the first compiled. One folder per instance name, as with temporary folders, so that two instances never
share files.

``<cache>`` is ``$OILWATCH_CACHE`` if set, else ``~/.cache/oilwatch``. ``OILWATCH_FMU_CACHE=0`` switches
the persistent folders off (a temporary folder per instance, deleted on close). A folder is created
atomically (unpacked under a temporary name, then renamed), so concurrent processes never see half an
FMU. Every FMU build has a new GUID, hence a new hash: each use touches its folder and only the
:data:`KEEP_FOLDERS` most recently used are kept. A folder in use is never pruned: its user holds a shared
``flock`` on ``<cache>/fmus/.locks/<folder>.lock`` from extraction to :meth:`Extraction.release` (the
loader's close, or the process's end), and :func:`prune` deletes a folder only under that file's exclusive
lock, taken without waiting (two test workers or two monitors sharing one cache never delete each other's
FMUs). Without ``fcntl`` (not POSIX) folders are pruned by age alone.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

from fmpy import extract

from oilwatch.models.cache import user_cache_dir

try:
    import fcntl
except ImportError:  # not POSIX: no folder locks
    fcntl = None

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


@dataclass
class Extraction:
    """An unpacked FMU: its ``folder``, whether it is the shared ``persistent`` one, and the lock that keeps
    a persistent folder from being pruned while it is used (a file descriptor, -1 for none)."""

    folder: Path
    persistent: bool
    lock: int = -1

    def release(self) -> None:
        """Done with the folder: unlock a persistent one, delete a temporary one (idempotent)."""
        if self.lock >= 0:
            os.close(self.lock)  # closing the descriptor drops its flock
            self.lock = -1
        if not self.persistent:
            shutil.rmtree(self.folder, ignore_errors=True)


def extract_fmu(path: Path, prefix: str) -> Extraction:
    """Unpack the FMU at ``path`` for the instance called ``prefix``.

    Persistent: the folder ``<cache>/fmus/oilwatch_<prefix>_<sha256>/``, reused by every later instance of
    that name and content and locked against pruning until :meth:`Extraction.release`; else (cache switched
    off or not writable) a new temporary folder ``oilwatch_<prefix>_*`` that release deletes.
    """
    if persistent_extraction_enabled():
        try:
            return _persistent_folder(Path(path), prefix)
        except OSError:
            pass  # a read-only home or full disk: fall back to a private temporary folder
    folder = Path(tempfile.mkdtemp(prefix=f"oilwatch_{prefix}_"))
    try:
        extract(str(path), unzipdir=str(folder))
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    return Extraction(folder, False)


def _lock_path(folder: Path) -> Path:
    return folder.parent / ".locks" / f"{folder.name}.lock"


def lock_folder(folder: Path) -> int:
    """A shared lock on ``folder``'s lock file (-1 without fcntl). Retried when a pruner unlinked the file
    between its opening and the lock, so that the lock held is always the one a pruner will test."""
    if fcntl is None:
        return -1
    path = _lock_path(folder)
    path.parent.mkdir(parents=True, exist_ok=True)
    while True:
        descriptor = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_SH)
            if os.path.exists(path) and os.path.samestat(os.fstat(descriptor), os.stat(path)):
                return descriptor
        except BaseException:
            os.close(descriptor)
            raise
        os.close(descriptor)


def _persistent_folder(path: Path, prefix: str) -> Extraction:
    parent = cache_root() / "fmus"
    folder = parent / f"oilwatch_{prefix}_{content_hash(path)}"
    parent.mkdir(parents=True, exist_ok=True)
    # locked before it is looked at: a pruner deletes a folder only while it holds the exclusive lock
    lock = lock_folder(folder)
    try:
        if _complete(folder):
            os.utime(folder)
            return Extraction(folder, True, lock)
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
    except BaseException:
        if lock >= 0:
            os.close(lock)
        raise
    prune(parent, KEEP_FOLDERS)
    return Extraction(folder, True, lock)


def prune(parent: Path, keep: int) -> None:
    """Delete all but the ``keep`` most recently modified folders in ``parent``; a folder whose lock another
    user holds is skipped (unfinished folders, named ``.partial-*``, are left to their writers)."""
    folders = [p for p in parent.iterdir() if p.is_dir() and not p.name.startswith(".")]
    folders.sort(key=lambda p: p.stat().st_mtime, reverse=True)
    for stale in folders[keep:]:
        _delete_unless_used(stale)


def _delete_unless_used(folder: Path) -> None:
    if fcntl is None:
        shutil.rmtree(folder, ignore_errors=True)
        return
    path = _lock_path(folder)
    path.parent.mkdir(parents=True, exist_ok=True)
    descriptor = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(descriptor)  # in use
        return
    try:
        shutil.rmtree(folder, ignore_errors=True)
        os.unlink(path)  # a user that opened it meanwhile sees it replaced and locks the new file
    finally:
        os.close(descriptor)
