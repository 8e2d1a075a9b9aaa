"""One writer per output: an exclusive ``flock`` on a lock file in the output folder, for the whole run.

The lock file (:data:`LOCK_NAME` in an output folder; ``.<file name>.lock`` beside an output file)
records its holder in one JSON line (pid, command, start time in UTC), so that a second writer is refused
at once with one line naming the holder. The kernel releases the lock when its holder dies (even by
SIGKILL), so the lock of a killed command is taken over by the next one without any clean-up; the file is
emptied, never removed, on release (a removed lock file would let a waiting opener lock a stale inode).
"""

from __future__ import annotations

import fcntl
import json
import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from oilwatch.models.validation import InputError

LOCK_NAME = "oilwatch.lock"


def lock_path_of(output: Path, kind: str) -> Path:
    """The lock file of an output ``folder`` or ``file`` (``kind``)."""
    return output / LOCK_NAME if kind == "folder" else output.parent / f".{output.name}.lock"


HOLDER_WAIT_S = 2.0
"""How long a refused writer waits for the holder's record: the holder writes it just after taking the lock,
and a second writer that arrives in between would otherwise name no holder."""


def _holder_text(handle) -> str:
    deadline = time.monotonic() + HOLDER_WAIT_S
    while True:
        handle.seek(0)
        text = handle.read().strip()
        if text.endswith("}") or time.monotonic() > deadline:
            break
        time.sleep(0.01)
    try:
        holder = json.loads(text)
        return f"oilwatch {holder['command']} (pid {holder['pid']}, started {holder['started']})"
    except (ValueError, KeyError, TypeError):
        return f"oilwatch (pid {text or 'unknown'})"


@contextmanager
def output_lock(
    output: str | Path, command: str, flag: str = "--out", kind: str = "folder"
) -> Iterator[Path]:
    """Hold the lock of ``output`` (a ``folder``, created if missing, or a ``file``) for the block, as
    ``command``; InputError naming ``flag``, the output and the holder when another live process holds it."""
    output = Path(output)
    folder = output if kind == "folder" else output.parent
    folder.mkdir(parents=True, exist_ok=True)
    path = lock_path_of(output, kind)
    handle = open(path, "a+", encoding="utf-8")
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise InputError(
                f"{flag} {str(output)!r}: {_holder_text(handle)} is writing this {kind}; wait for it to "
                f"finish or use another {flag}"
            ) from None
        started = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
        record = {"pid": os.getpid(), "command": command, "started": started}
        handle.seek(0)
        handle.truncate()
        handle.write(json.dumps(record) + "\n")
        handle.flush()
        try:
            yield path
        finally:
            handle.seek(0)
            handle.truncate()
            handle.flush()
    finally:
        handle.close()
