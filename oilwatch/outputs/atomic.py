"""Files and folders that appear whole under their final name or not at all.

A file is written under a temporary name of its own in the target's folder (``.<name>.<random>.tmp``:
unique per writer, so two writers never rename each other's file away), synced, and renamed over the
target; a rename within one folder is atomic, so a reader sees the old file or the new one, never half of
either. A write that fails (disk full, interrupted) removes its temporary file and leaves the target as it
was, and raises :class:`.rows.OutputError` naming the target. Interrupts (:mod:`.interrupts`) are held
back across the rename, so that a stop never falls between the rename and the removal of the temporary
name.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

from . import interrupts
from .rows import OutputError, describe_os_error

FILE_MODE = 0o644  # mkstemp's 0600 would hide the outputs from the machine's other users


def sync_folder(folder: Path) -> None:
    """Make a rename in ``folder`` durable (a no-op where folders cannot be opened)."""
    try:
        handle = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        with suppress(OSError):
            os.fsync(handle)
    finally:
        os.close(handle)


def temporary_name(path: Path) -> Path:
    """A new, empty temporary file beside ``path`` (created 0644)."""
    handle, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(handle, FILE_MODE)
    finally:
        os.close(handle)
    return Path(name)


def commit(temporary: Path, path: Path) -> Path:
    """Sync ``temporary`` and rename it over ``path`` (signals held back meanwhile); return ``path``."""
    with interrupts.deferred():
        handle = os.open(temporary, os.O_RDONLY)
        try:
            os.fsync(handle)
        finally:
            os.close(handle)
        os.replace(temporary, path)
        sync_folder(path.parent)
    return path


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` for a writer that takes a file name (matplotlib, zipfile,
    a library's builder); on a normal exit it becomes ``path``, on an exception it is removed."""
    path = Path(path)
    temporary = temporary_name(path)
    try:
        yield temporary
        commit(temporary, path)
    except OSError as error:  # a full or read-only disk: one line naming the file, not the temporary
        temporary.unlink(missing_ok=True)
        raise OutputError(f"cannot write {path}: {describe_os_error(error)}") from None
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def write_bytes_atomic(path: str | Path, data: bytes) -> Path:
    """Write ``data`` as ``path``, whole or not at all."""
    path = Path(path)
    with atomic_path(path) as temporary:
        temporary.write_bytes(data)
    return path


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) as ``path``, whole or not at all."""
    return write_bytes_atomic(path, text.encode("utf-8"))


def write_json_atomic(path: str | Path, payload: dict) -> Path:
    """Write ``payload`` as indented JSON to ``path``, whole or not at all."""
    return write_text_atomic(path, json.dumps(payload, indent=1) + "\n")


@contextmanager
def atomic_folder(path: str | Path) -> Iterator[Path]:
    """Yield a new temporary folder beside ``path`` (``.<name>.<random>.partial``); on a normal exit it
    replaces ``path`` (an earlier folder of that name is moved aside and removed), on an exception it is
    removed. A reader sees the old folder, then the new one, never a folder being filled."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent))
    try:
        yield staging
        with interrupts.deferred():
            old = None
            if path.exists():
                old = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".old", dir=path.parent))
                os.replace(path, old / path.name)
            os.replace(staging, path)
            sync_folder(path.parent)
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
