"""A CSV stream that holds whole rows only: the ``estimates.csv`` of ``estimate``, the ``result.csv`` of
``run``.

Rows are written in whole blocks (one or more complete lines) with the operating system's ``write``,
unbuffered, and signals held back (:func:`.interrupts.deferred`), so a SIGINT or SIGTERM never falls inside
a row. A write that fails (disk full, quota, I/O error) is cut back to the end of the last whole block
(``ftruncate`` needs no free space), so the file still ends on a row boundary; the error then propagates
as :class:`OutputError`, naming the file and what it keeps. Only a SIGKILL or a power cut can tear the
last row; :func:`whole_rows_length` finds where the whole rows end (a resumed run cuts there).
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

from oilwatch.models.validation import InputError

from . import interrupts

WRITE_ERRORS = {
    errno.ENOSPC: "the disk is full",
    errno.EDQUOT: "the disk quota is exceeded",
    errno.EROFS: "the file system is read-only",
    errno.EACCES: "permission denied",
    errno.EPERM: "operation not permitted",
    errno.EIO: "input/output error",
    errno.EFBIG: "the file is too large",
}


class OutputError(InputError):
    """An output could not be written: the path and the reason (:func:`oilwatch.cli.main` adds what was
    kept, :mod:`.ledger`; exit code 2, as every InputError)."""


def describe_os_error(error: OSError) -> str:
    """The reason of ``error`` in words, with its errno name (``the disk is full (ENOSPC)``)."""
    name = errno.errorcode.get(error.errno or 0, "")
    reason = WRITE_ERRORS.get(error.errno or 0, error.strerror or str(error))
    return f"{reason} ({name})" if name else reason


def whole_rows_length(path: Path) -> int:
    """The length of ``path`` up to the end of its last complete line (0 for a missing file)."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return 0
    return data.rfind(b"\n") + 1


class RowFile:
    """``path`` opened for whole-row writes: a new file (``append`` False) or an existing one cut back to
    its ``keep_bytes`` first bytes, ``keep_lines`` lines (a resumed run). ``write(text)`` takes complete
    lines; ``lines`` counts the lines in the file (a header's included)."""

    def __init__(
        self,
        path: str | Path,
        append: bool = False,
        keep_bytes: int = 0,
        keep_lines: int = 0,
        sync_every: int = 1,
    ) -> None:
        self.path = Path(path)
        flags = os.O_WRONLY | os.O_CREAT | (0 if append else os.O_TRUNC)
        self._fd = os.open(self.path, flags, 0o644)
        self.committed = 0
        if append:
            os.ftruncate(self._fd, keep_bytes)
            self.committed = keep_bytes
        os.lseek(self._fd, self.committed, os.SEEK_SET)
        self.lines = keep_lines if append else 0
        self.sync_every = max(1, int(sync_every))
        self._writes = 0

    def write(self, text: str) -> None:
        """Append ``text`` (whole lines) at once; :class:`OutputError` (file cut back) if it cannot be."""
        if not text:
            return
        data = text.encode("utf-8")
        with interrupts.deferred():
            try:
                view = memoryview(data)
                while view:
                    written = os.write(self._fd, view)
                    view = view[written:]
                self._writes += 1
                if self._writes % self.sync_every == 0:
                    os.fsync(self._fd)
            except OSError as error:
                self._cut_back()
                raise OutputError(f"cannot write {self.path}: {describe_os_error(error)}") from None
            self.committed += len(data)
            self.lines += data.count(b"\n")

    def _cut_back(self) -> None:
        try:
            os.ftruncate(self._fd, self.committed)
            os.lseek(self._fd, self.committed, os.SEEK_SET)
        except OSError:
            pass  # the file is as the failed write left it; a resumed run cuts it at the last whole row

    def flush(self) -> None:
        """Nothing buffered: every write is already in the file (text-stream interface)."""

    def sync(self) -> None:
        """Make the rows written so far durable."""
        if self._fd < 0:
            return
        try:
            os.fsync(self._fd)
        except OSError:
            pass

    def close(self) -> None:
        """Sync and close (idempotent)."""
        if self._fd >= 0:
            self.sync()
            os.close(self._fd)
            self._fd = -1

    def __enter__(self) -> RowFile:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
